//! Latency statistics from an HDR histogram (1 ns .. 60 s, 3 significant digits).

use hdrhistogram::Histogram;
use serde::Serialize;

/// Quantiles, extremes and spread of a latency sample, in milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Latency {
    /// Samples.
    pub count: u64,
    /// Smallest.
    pub min_ms: f64,
    /// Median.
    pub p50_ms: f64,
    /// 90th percentile.
    pub p90_ms: f64,
    /// 99th percentile.
    pub p99_ms: f64,
    /// 99.9th percentile.
    pub p999_ms: f64,
    /// Largest.
    pub max_ms: f64,
    /// Mean.
    pub mean_ms: f64,
    /// Standard deviation (jitter).
    pub stdev_ms: f64,
    /// Jitter as max - p50.
    pub jitter_ms: f64,
}

/// Why statistics could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum StatsError {
    /// No samples.
    #[error("no latency samples")]
    Empty,
    /// The histogram could not be created.
    #[error("histogram: {0}")]
    Histogram(String),
}

/// Summarises latencies given in nanoseconds (values above 60 s saturate).
pub fn latency(samples_ns: &[u64]) -> Result<Latency, StatsError> {
    if samples_ns.is_empty() {
        return Err(StatsError::Empty);
    }
    let mut h = Histogram::<u64>::new_with_bounds(1, 60_000_000_000, 3)
        .map_err(|e| StatsError::Histogram(e.to_string()))?;
    for &v in samples_ns {
        h.saturating_record(v.max(1));
    }
    let ms = |ns: u64| ns as f64 * 1e-6;
    let p50 = ms(h.value_at_quantile(0.5));
    let max = ms(h.max());
    Ok(Latency {
        count: h.len(),
        min_ms: ms(h.min()),
        p50_ms: p50,
        p90_ms: ms(h.value_at_quantile(0.9)),
        p99_ms: ms(h.value_at_quantile(0.99)),
        p999_ms: ms(h.value_at_quantile(0.999)),
        max_ms: max,
        mean_ms: h.mean() * 1e-6,
        stdev_ms: h.stdev() * 1e-6,
        jitter_ms: max - p50,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_a_known_sample() {
        // 1..=1000 ms: p50 = 500 ms, p99 = 990 ms, max = 1000 ms (3 significant digits).
        let v: Vec<u64> = (1..=1000).map(|i| i * 1_000_000).collect();
        let l = latency(&v).unwrap();
        assert_eq!(l.count, 1000);
        assert!((l.p50_ms - 500.0).abs() < 1.0, "{l:?}");
        assert!((l.p99_ms - 990.0).abs() < 1.5, "{l:?}");
        assert!((l.max_ms - 1000.0).abs() < 1.0, "{l:?}");
        assert!((l.jitter_ms - 500.0).abs() < 2.0, "{l:?}");
        assert!((l.stdev_ms - 288.7).abs() < 1.0, "{l:?}");
    }

    #[test]
    fn empty_sample_is_an_error() {
        assert!(matches!(latency(&[]), Err(StatsError::Empty)));
    }
}
