//! Little-endian CDR (the ROS 2 wire format) for [`PlanInput`], [`PlanOutput`] and
//! [`PlanWarmStart`].
//!
//! A 4-byte encapsulation header `[0, 1, 0, 0]`, then the fields in schema order, each
//! aligned to its size counted from the byte after the header; strings and sequences carry
//! a u32 length. Doubles are written as their raw bits, so decoding is bit-exact.

use crate::msg::{
    PlanInput, PlanOutput, PlanWarmStart, CONTROL_LEN, SETTINGS_LEN, STATE_LEN, VEHICLE_LEN,
};

/// The CDR encapsulation header (little-endian plain CDR).
pub const HEADER: [u8; 4] = [0, 1, 0, 0];

/// Largest string or sequence a decoder accepts (elements).
pub const MAX_SEQUENCE: usize = 1 << 20;

/// Why a CDR payload could not be decoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecodeError {
    /// The payload does not start with the little-endian CDR header.
    #[error("bad CDR header {found:02x?} (expected 00 01 00 00)")]
    Header {
        /// The first bytes found.
        found: Vec<u8>,
    },
    /// The payload ended inside a field.
    #[error(
        "field `{field}` at byte {offset}: payload ends (needs {needed} bytes, {available} left)"
    )]
    Truncated {
        /// Field being read.
        field: &'static str,
        /// Byte offset in the payload.
        offset: usize,
        /// Bytes needed.
        needed: usize,
        /// Bytes left.
        available: usize,
    },
    /// A field has a value outside its domain.
    #[error("field `{field}` at byte {offset}: {problem}")]
    Invalid {
        /// Field being read.
        field: &'static str,
        /// Byte offset in the payload.
        offset: usize,
        /// What is wrong.
        problem: String,
    },
    /// Bytes remain after the last field.
    #[error("{extra} unexpected bytes after the last field (at byte {offset})")]
    Trailing {
        /// Offset of the first extra byte.
        offset: usize,
        /// How many.
        extra: usize,
    },
}

/// Appends CDR fields to a reusable buffer.
#[derive(Debug, Default)]
pub struct Encoder {
    buf: Vec<u8>,
}

impl Encoder {
    /// Clears the buffer and writes the header.
    pub fn start(&mut self) {
        self.buf.clear();
        self.buf.extend_from_slice(&HEADER);
    }
    /// The encoded bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.buf
    }
    fn align(&mut self, n: usize) {
        while !(self.buf.len() - HEADER.len()).is_multiple_of(n) {
            self.buf.push(0);
        }
    }
    fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }
    fn string(&mut self, s: &str) {
        // Length counts the terminating NUL; interior NULs cannot be represented.
        let clean: String = s.chars().filter(|c| *c != '\0').collect();
        self.u32(clean.len() as u32 + 1);
        self.buf.extend_from_slice(clean.as_bytes());
        self.buf.push(0);
    }
    fn f64_array(&mut self, v: &[f64]) {
        for x in v {
            self.f64(*x);
        }
    }
    fn f64_seq(&mut self, v: impl ExactSizeIterator<Item = f64>) {
        self.u32(v.len() as u32);
        for x in v {
            self.f64(x);
        }
    }
}

/// Reads CDR fields with bounds checks; every error names the field and byte offset.
#[derive(Debug)]
pub struct Decoder<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Decoder<'a> {
    /// Checks the header and positions after it.
    pub fn new(data: &'a [u8]) -> Result<Self, DecodeError> {
        if data.len() < HEADER.len() || data[..HEADER.len()] != HEADER {
            return Err(DecodeError::Header {
                found: data[..data.len().min(HEADER.len())].to_vec(),
            });
        }
        Ok(Self {
            data,
            pos: HEADER.len(),
        })
    }
    fn take(
        &mut self,
        field: &'static str,
        align: usize,
        n: usize,
    ) -> Result<&'a [u8], DecodeError> {
        let pad = (align - (self.pos - HEADER.len()) % align) % align;
        let start = self.pos + pad;
        let available = self.data.len().saturating_sub(start);
        if n > available {
            return Err(DecodeError::Truncated {
                field,
                offset: start.min(self.data.len()),
                needed: n,
                available,
            });
        }
        self.pos = start + n;
        Ok(&self.data[start..start + n])
    }
    fn u32(&mut self, field: &'static str) -> Result<u32, DecodeError> {
        let b = self.take(field, 4, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self, field: &'static str) -> Result<u64, DecodeError> {
        let b = self.take(field, 8, 8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
    fn f64(&mut self, field: &'static str) -> Result<f64, DecodeError> {
        Ok(f64::from_bits(self.u64(field)?))
    }
    fn bool(&mut self, field: &'static str) -> Result<bool, DecodeError> {
        let offset = self.pos;
        match self.take(field, 1, 1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(DecodeError::Invalid {
                field,
                offset,
                problem: format!("boolean byte {b} (expected 0 or 1)"),
            }),
        }
    }
    fn len(&mut self, field: &'static str, elem: usize) -> Result<usize, DecodeError> {
        let offset = self.pos;
        let n = self.u32(field)? as usize;
        let left = self.data.len().saturating_sub(self.pos);
        if n > MAX_SEQUENCE || n.saturating_mul(elem) > left + 7 {
            return Err(DecodeError::Invalid {
                field,
                offset,
                problem: format!("length {n} exceeds the {left} bytes left"),
            });
        }
        Ok(n)
    }
    fn string(&mut self, field: &'static str) -> Result<String, DecodeError> {
        let n = self.len(field, 1)?;
        let offset = self.pos;
        let bytes = self.take(field, 1, n)?;
        let Some((&0, body)) = bytes.split_last() else {
            return Err(DecodeError::Invalid {
                field,
                offset,
                problem: "string is not NUL-terminated".into(),
            });
        };
        String::from_utf8(body.to_vec()).map_err(|e| DecodeError::Invalid {
            field,
            offset,
            problem: format!("not UTF-8: {e}"),
        })
    }
    fn f64_array<const K: usize>(&mut self, field: &'static str) -> Result<[f64; K], DecodeError> {
        let mut out = [0.0; K];
        for v in &mut out {
            *v = self.f64(field)?;
        }
        Ok(out)
    }
    fn f64_seq(&mut self, field: &'static str) -> Result<Vec<f64>, DecodeError> {
        let n = self.len(field, 8)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            out.push(self.f64(field)?);
        }
        Ok(out)
    }
    /// Fails unless every byte was consumed.
    pub fn finish(self) -> Result<(), DecodeError> {
        if self.pos == self.data.len() {
            Ok(())
        } else {
            Err(DecodeError::Trailing {
                offset: self.pos,
                extra: self.data.len() - self.pos,
            })
        }
    }
}

/// Encodes an input (schema [`crate::schema::PLAN_INPUT_MSG`]).
pub fn encode_input(e: &mut Encoder, m: &PlanInput) {
    e.start();
    e.u64(m.seq);
    e.u64(m.stamp_ns);
    e.string(&m.scenario);
    e.string(&m.guess);
    e.u32(m.n_intervals);
    e.f64(m.length_m);
    e.f64(m.v_min_mps);
    e.f64(m.v_max_mps);
    e.f64(m.v_end_max_mps);
    e.f64(m.steering_slew_weight);
    e.f64(m.soft_lane_weight);
    e.bool(m.enforce_tire_saturation);
    e.bool(m.saturation_at_end);
    e.bool(m.initial_state_fixed);
    e.f64_array(&m.x0);
    e.f64_seq(m.kappa.iter().copied());
    e.f64_seq(m.e_min.iter().copied());
    e.f64_seq(m.e_max.iter().copied());
    e.f64_seq(m.soft_e_min.iter().copied());
    e.f64_seq(m.soft_e_max.iter().copied());
    e.f64_array(&m.vehicle);
    e.f64_array(&m.settings);
    e.u64(m.config_hash);
    e.string(&m.settings_json);
}

/// Decodes an input; the whole payload must be consumed.
pub fn decode_input(data: &[u8]) -> Result<PlanInput, DecodeError> {
    let mut d = Decoder::new(data)?;
    let m = PlanInput {
        seq: d.u64("seq")?,
        stamp_ns: d.u64("stamp_ns")?,
        scenario: d.string("scenario")?,
        guess: d.string("guess")?,
        n_intervals: d.u32("n_intervals")?,
        length_m: d.f64("length_m")?,
        v_min_mps: d.f64("v_min_mps")?,
        v_max_mps: d.f64("v_max_mps")?,
        v_end_max_mps: d.f64("v_end_max_mps")?,
        steering_slew_weight: d.f64("steering_slew_weight")?,
        soft_lane_weight: d.f64("soft_lane_weight")?,
        enforce_tire_saturation: d.bool("enforce_tire_saturation")?,
        saturation_at_end: d.bool("saturation_at_end")?,
        initial_state_fixed: d.bool("initial_state_fixed")?,
        x0: d.f64_array::<STATE_LEN>("x0")?,
        kappa: d.f64_seq("kappa")?,
        e_min: d.f64_seq("e_min")?,
        e_max: d.f64_seq("e_max")?,
        soft_e_min: d.f64_seq("soft_e_min")?,
        soft_e_max: d.f64_seq("soft_e_max")?,
        vehicle: d.f64_array::<VEHICLE_LEN>("vehicle")?,
        settings: d.f64_array::<SETTINGS_LEN>("settings")?,
        config_hash: d.u64("config_hash")?,
        settings_json: d.string("settings_json")?,
    };
    d.finish()?;
    Ok(m)
}

/// Encodes an output (schema [`crate::schema::PLAN_OUTPUT_MSG`]); states and controls
/// go column by column, one `float64[]` per state or control.
pub fn encode_output(e: &mut Encoder, m: &PlanOutput) {
    e.start();
    e.u64(m.seq);
    e.u64(m.stamp_ns);
    e.string(&m.status);
    e.u32(m.iterations);
    e.f64(m.objective);
    e.f64(m.max_violation);
    e.f64(m.t_final_s);
    e.u32(m.factorizations);
    e.u32(m.evaluations);
    e.f64(m.time_evaluation_s);
    e.f64(m.time_factorization_s);
    e.f64(m.time_solve_s);
    e.f64(m.time_line_search_s);
    e.f64(m.time_total_s);
    encode_columns(e, &m.states, &m.controls);
}

/// States and controls column by column, one `float64[]` per state or control.
fn encode_columns(e: &mut Encoder, states: &[[f64; STATE_LEN]], controls: &[[f64; CONTROL_LEN]]) {
    for i in 0..STATE_LEN {
        e.f64_seq(states.iter().map(|x| x[i]));
    }
    for i in 0..CONTROL_LEN {
        e.f64_seq(controls.iter().map(|u| u[i]));
    }
}

/// Field names of the state columns (for error messages).
const STATE_FIELDS: [&str; STATE_LEN] = crate::msg::STATE_NAMES;
/// Field names of the control columns (for error messages).
const CONTROL_FIELDS: [&str; CONTROL_LEN] = crate::msg::CONTROL_NAMES;

/// Decodes an output; every state column must have the same length, and so must every
/// control column.
pub fn decode_output(data: &[u8]) -> Result<PlanOutput, DecodeError> {
    let mut d = Decoder::new(data)?;
    let mut m = PlanOutput {
        seq: d.u64("seq")?,
        stamp_ns: d.u64("stamp_ns")?,
        status: d.string("status")?,
        iterations: d.u32("iterations")?,
        objective: d.f64("objective")?,
        max_violation: d.f64("max_violation")?,
        t_final_s: d.f64("t_final_s")?,
        factorizations: d.u32("factorizations")?,
        evaluations: d.u32("evaluations")?,
        time_evaluation_s: d.f64("time_evaluation_s")?,
        time_factorization_s: d.f64("time_factorization_s")?,
        time_solve_s: d.f64("time_solve_s")?,
        time_line_search_s: d.f64("time_line_search_s")?,
        time_total_s: d.f64("time_total_s")?,
        states: Vec::new(),
        controls: Vec::new(),
    };
    (m.states, m.controls) = decode_columns(&mut d)?;
    d.finish()?;
    Ok(m)
}

/// The columns [`encode_columns`] wrote; every state column must have the same length, and
/// so must every control column.
#[allow(clippy::type_complexity)]
fn decode_columns(
    d: &mut Decoder<'_>,
) -> Result<(Vec<[f64; STATE_LEN]>, Vec<[f64; CONTROL_LEN]>), DecodeError> {
    Ok((
        decode_rows(d, &STATE_FIELDS)?,
        decode_rows(d, &CONTROL_FIELDS)?,
    ))
}

/// K columns named `fields`, one `float64[]` each, as rows of K values; every column must
/// have the length of the first.
fn decode_rows<const K: usize>(
    d: &mut Decoder<'_>,
    fields: &[&'static str; K],
) -> Result<Vec<[f64; K]>, DecodeError> {
    let mut rows = Vec::new();
    for (i, field) in fields.iter().enumerate() {
        let offset = d.pos;
        let col = d.f64_seq(field)?;
        if i == 0 {
            rows = vec![[0.0; K]; col.len()];
        } else if col.len() != rows.len() {
            return Err(DecodeError::Invalid {
                field,
                offset,
                problem: format!(
                    "{} values, but `{}` has {}",
                    col.len(),
                    fields[0],
                    rows.len()
                ),
            });
        }
        for (x, v) in rows.iter_mut().zip(col) {
            x[i] = v;
        }
    }
    Ok(rows)
}

/// Encodes a warm start (schema [`crate::schema::PLAN_WARM_MSG`]).
pub fn encode_warm(e: &mut Encoder, m: &PlanWarmStart) {
    e.start();
    e.u64(m.seq);
    e.u64(m.stamp_ns);
    e.f64(m.shift_m);
    e.u64(m.warm_max_iter);
    e.f64(m.mu_floor);
    e.string(&m.mu_match);
    e.f64(m.mu_match_factor);
    e.string(&m.cold_guess);
    encode_columns(e, &m.states, &m.controls);
    e.f64_seq(m.y.iter().copied());
    e.f64_seq(m.zl.iter().copied());
    e.f64_seq(m.zu.iter().copied());
}

/// Decodes a warm start; the whole payload must be consumed.
pub fn decode_warm(data: &[u8]) -> Result<PlanWarmStart, DecodeError> {
    let mut d = Decoder::new(data)?;
    let mut m = PlanWarmStart {
        seq: d.u64("seq")?,
        stamp_ns: d.u64("stamp_ns")?,
        shift_m: d.f64("shift_m")?,
        warm_max_iter: d.u64("warm_max_iter")?,
        mu_floor: d.f64("mu_floor")?,
        mu_match: d.string("mu_match")?,
        mu_match_factor: d.f64("mu_match_factor")?,
        cold_guess: d.string("cold_guess")?,
        states: Vec::new(),
        controls: Vec::new(),
        y: Vec::new(),
        zl: Vec::new(),
        zu: Vec::new(),
    };
    (m.states, m.controls) = decode_columns(&mut d)?;
    m.y = d.f64_seq("y")?;
    m.zl = d.f64_seq("zl")?;
    m.zu = d.f64_seq("zu")?;
    d.finish()?;
    Ok(m)
}
