//! Configuration files (vehicle, scenarios, solver settings): serde types and validation.
