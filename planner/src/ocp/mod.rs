//! The NLP view of the minimum-time OCP (paper eq. 3): problem data, variable layout,
//! scaling, and transcriptions that evaluate into preallocated buffers.

pub(crate) mod ad;
pub mod fast;
#[doc(hidden)]
pub mod fixtures;
pub mod jet;
pub mod layout;
pub mod objective;
pub mod path_constraints;
pub mod scaling;
pub mod soft_lane;
pub mod spec;
pub mod transcription;

pub use layout::Layout;
pub use soft_lane::SoftLane;
pub use spec::{InitialState, OcpSpec, SpecError, MAX_STEERING_SLEW_WEIGHT};
pub use transcription::{
    CrankNicolson, DefectScheme, Derivatives, ExplicitRk2, ExplicitRk4, GaussLegendre2,
    GaussLegendre3, ImplicitEuler, ImplicitEulerNlp, LinearMultistep, MultistepFamily, RowInfo,
    RowKind, Transcription, TranscriptionError,
};
