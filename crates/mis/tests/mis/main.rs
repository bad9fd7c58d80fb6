//! Properties of the MIS weights on constructed paths: the recursion equals the
//! explicit reference, the weights of all techniques sum to 1, stiff inputs
//! stay finite, and broken variants (the supplemental's shortcut, a virtual
//! merge known only to its own technique) are caught.

mod negative_control;
mod paths;
mod recursion;
mod stiff;
