//! Latency statistics with fixed-bucket HDR histograms (recording allocates nothing).

use hdrhistogram::Histogram;

/// A latency histogram in nanoseconds, 1 ns to 100 s at 3 significant digits.
#[derive(Debug, Clone)]
pub struct Latency {
    h: Histogram<u64>,
}

impl Default for Latency {
    fn default() -> Self {
        Self::new()
    }
}

impl Latency {
    /// Allocates the buckets once.
    pub fn new() -> Self {
        let h = Histogram::new_with_bounds(1, 100_000_000_000, 3)
            .unwrap_or_else(|_| Histogram::new(3).unwrap_or_else(|_| unreachable!()));
        Self { h }
    }

    /// Records one sample \[ns\] (clamped into range; allocates nothing).
    pub fn record_ns(&mut self, ns: u64) {
        self.h.saturating_record(ns.max(1));
    }

    /// Number of samples.
    pub fn count(&self) -> u64 {
        self.h.len()
    }

    /// Quantile q in [0, 1] \[ns\] (0 when empty).
    pub fn quantile_ns(&self, q: f64) -> u64 {
        if self.h.is_empty() {
            0
        } else {
            self.h.value_at_quantile(q)
        }
    }

    /// Largest sample \[ns\].
    pub fn max_ns(&self) -> u64 {
        self.h.max()
    }

    /// p50/p99/max in microseconds, as JSON (null when empty).
    pub fn json_us(&self) -> serde_json::Value {
        if self.h.is_empty() {
            return serde_json::json!({ "count": 0, "p50": null, "p99": null, "max": null });
        }
        serde_json::json!({
            "count": self.count(),
            "p50": self.quantile_ns(0.5) as f64 * 1e-3,
            "p99": self.quantile_ns(0.99) as f64 * 1e-3,
            "max": self.max_ns() as f64 * 1e-3,
        })
    }
}
