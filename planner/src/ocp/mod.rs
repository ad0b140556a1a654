//! The NLP view of the minimum-time OCP (paper eq. 3): problem data, variable layout,
//! scaling, and transcriptions that evaluate into preallocated buffers.

pub mod spec;

pub use spec::{InitialState, OcpSpec};
