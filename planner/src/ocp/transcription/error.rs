//! Errors building or updating a transcription.

/// Errors building a transcription.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TranscriptionError {
    /// The spec's interval count differs from the compiled-in N.
    #[error("spec has {got} intervals, this transcription is built for N = {expected}")]
    WrongN {
        /// Compiled-in N.
        expected: usize,
        /// spec.n_intervals.
        got: usize,
    },
    /// A per-node vector has the wrong length.
    #[error("spec field {field} has {got} entries, expected N + 1 = {expected}")]
    BadLength {
        /// Field name.
        field: &'static str,
        /// N + 1.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// Soft lane bounds given to a transcription built without a soft lane.
    #[error("the spec has no soft lane (weight 0): its bounds cannot be updated")]
    SoftLaneOff,
    /// An end-speed bound that leaves the last node no speed.
    #[error("end speed bound {value} m/s does not exceed v_min = {v_min} m/s")]
    EndSpeed {
        /// The bound given.
        value: f64,
        /// The spec's lower speed bound.
        v_min: f64,
    },
}

/// Checks that every per-node vector (`(field, length)` pairs) has N + 1 entries; the first
/// that does not is the error.
pub(super) fn check_node_vectors<const N: usize, const F: usize>(
    fields: [(&'static str, usize); F],
) -> Result<(), TranscriptionError> {
    for (field, len) in fields {
        if len != N + 1 {
            return Err(TranscriptionError::BadLength {
                field,
                expected: N + 1,
                got: len,
            });
        }
    }
    Ok(())
}
