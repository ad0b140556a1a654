//! Sample statistics of repeated measurements (solve times over repeats).

/// The median of `samples`: the middle value of the sorted samples for an odd count, the
/// mean of the two middle ones for an even count; NaN when empty. Sorts `samples` in place
/// (by [`f64::total_cmp`]).
pub fn median(samples: &mut [f64]) -> f64 {
    if samples.is_empty() {
        return f64::NAN;
    }
    samples.sort_by(f64::total_cmp);
    let n = samples.len();
    if n % 2 == 1 {
        samples[n / 2]
    } else {
        0.5 * (samples[n / 2 - 1] + samples[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn median_of_two_is_their_mean() {
        assert_eq!(median(&mut [5.0, 1.0]), 3.0);
    }
}
