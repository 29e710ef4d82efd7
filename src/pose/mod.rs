//! The rest of the pose: translation and scale from the profile shifts, and
//! the verification's geometry (the OR-pooled pyramid, the branch-and-bound
//! search over translations, and ICP).
//!
//! * [`translation`]: the least-squares translation from column shifts;
//! * [`scale`]: the bounded 1-D scale search;
//! * [`pyramid`]: the OR-pooled reference pyramid;
//! * [`reach`]: per-level reach tables of the reference (feature
//!   `reach-tables`, on by default);
//! * [`search`]: the alignment score and the exact best translation;
//! * [`icp`]: the sub-cell, sub-step refinement;
//! * [`agreement`]: a pose judged both ways on a large sample, with the
//!   views' free space: the decision between candidates.

pub(crate) mod agreement;
mod bound;
pub(crate) mod icp;
pub(crate) mod points;
pub(crate) mod pyramid;
pub(crate) mod reach;
pub(crate) mod scale;
pub(crate) mod search;
pub(crate) mod translation;

pub use translation::{fit_translation, ColumnShift, Pose, MAX_FIT_COLUMNS};
