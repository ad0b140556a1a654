//! Road ahead: curvature k_ref(s), lane bounds e_min(s)/e_max(s), obstacles, segments.
//!
//! [`Profile`] is a closed track on a uniform s grid (the canonical `*_profile.csv`, or
//! smoothed from a raw centerline by [`Profile::from_centerline`]); [`Segment`] cuts a
//! horizon out of it and samples a [`Road`] at the OCP nodes; [`BoundsOverride`] puts
//! obstacles into the lateral bounds. Loading a track file fails with a [`TrackFileError`].
//! [`import`] turns a raw centerline into a named track of a data root; [`map`] rebuilds a
//! track in the plane and finds its corners.

mod centerline;
mod csv;
mod error;
pub mod import;
pub mod map;
mod profile;
mod segment;
mod shape;

pub use centerline::{
    smooth_centerline, CenterlineStats, SmoothedCenterline, KNOT_SPACING_M, PENALTY_LAMBDA,
};
pub use error::TrackFileError;
pub use profile::{Profile, PROFILE_COLUMNS};
pub use segment::{beyond_curvature_centre, piecewise_constant, BoundsOverride, Road, Segment};
pub use shape::{MAX_POINTS, MIN_POINTS};
