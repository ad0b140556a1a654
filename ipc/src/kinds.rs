//! Counts of plans by kind ([`PlanKind`]): what the planner published and what the
//! tracker drove.

use crate::msg::PlanKind;

/// How many plans of each kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KindCounts {
    /// Converged plans.
    pub converged: u64,
    /// Best iterates within the drivable violation.
    pub best_iterate: u64,
    /// Previous plans shifted to the car's s.
    pub previous_shifted: u64,
}

impl KindCounts {
    /// Counts one plan of kind `kind`.
    pub fn count(&mut self, kind: PlanKind) {
        match kind {
            PlanKind::Converged => self.converged += 1,
            PlanKind::BestIterate => self.best_iterate += 1,
            PlanKind::PreviousShifted => self.previous_shifted += 1,
        }
    }

    /// Counts one plan by its wire code (an unknown code counts nothing).
    pub fn count_code(&mut self, code: u32) {
        if let Some(kind) = PlanKind::from_code(code) {
            self.count(kind);
        }
    }

    /// Total counted.
    pub fn total(&self) -> u64 {
        self.converged + self.best_iterate + self.previous_shifted
    }

    /// Adds `plans_converged`, `plans_best_iterate` and `plans_previous_shifted` to a JSON
    /// object.
    pub fn add_json(&self, obj: &mut serde_json::Value) {
        obj["plans_converged"] = self.converged.into();
        obj["plans_best_iterate"] = self.best_iterate.into();
        obj["plans_previous_shifted"] = self.previous_shifted.into();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_counted_under_its_own_json_field() {
        let mut c = KindCounts::default();
        c.count(PlanKind::Converged);
        c.count_code(PlanKind::BestIterate.code());
        c.count_code(PlanKind::PreviousShifted.code());
        c.count_code(PlanKind::PreviousShifted.code());
        c.count_code(7);
        assert_eq!(c.total(), 4);
        let mut v = serde_json::json!({});
        c.add_json(&mut v);
        assert_eq!(
            v,
            serde_json::json!({
                "plans_converged": 1,
                "plans_best_iterate": 1,
                "plans_previous_shifted": 2,
            })
        );
    }
}
