//! The energy tables a compensated lobe reads, named so that a renderer can
//! build them when it chooses (at start-up, in parallel) instead of inside
//! the first `Bsdf::regularized` call that needs them.
//!
//! Every table is computed by quadrature once per process and shared
//! (`OnceLock`): there are no data files. Their cost, release build, one
//! core of a 2-core x86-64 machine: a reflection model's albedo table
//! 0.25-1.7 s and its gain scaling 0.4-3.2 s (by NDF and shadowing); for a
//! dielectric at one index ratio, the four critical-cosine slices of its
//! albedo 1.3-18 s and its gain scaling 0.1-10 s. From a dependent crate
//! (2 cores under load), the first regularization of a GGX conductor took
//! 0.26 s and of smooth glass 2.5 s; unoptimised (debug) builds of this
//! crate take about ten times longer (2.9 s, 23 s): a dependent can
//! optimise it alone with `[profile.dev.package.rlt-microfacet]
//! opt-level = 3`.

use crate::bsdf::Bsdf;
use crate::compensation::dielectric_energy::{DielectricAlbedoTable, dielectric_albedo_table};
use crate::compensation::dielectric_gain::{
    mean_scale_slice, mean_scale_slice_is_built, slices_read,
};
use crate::compensation::energy::{albedo_table, albedo_table_is_built};
use crate::compensation::gain::{mean_scale_table, mean_scale_table_is_built};
use crate::ndf::NdfKind;
use crate::shadowing::Shadowing;

/// One energy table, or one slice of a dielectric's, of an NDF family with
/// a shadowing model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum EnergyTable {
    /// The directional albedo E(mu, alpha) of reflection (`energy`).
    Albedo(NdfKind, Shadowing),
    /// The mean scale of a widened reflection lobe that gains (`gain`).
    MeanScale(NdfKind, Shadowing),
    /// One critical-cosine slice of an interface's energy albedo
    /// (`dielectric_energy`).
    DielectricAlbedo(NdfKind, Shadowing, usize),
    /// One critical-cosine slice of an interface's mean scale
    /// (`dielectric_gain`).
    DielectricMeanScale(NdfKind, Shadowing, usize),
}

impl EnergyTable {
    /// The tables a compensated reflection lobe (conductor, coat) reads.
    pub fn of_reflection(kind: NdfKind, shadowing: Shadowing) -> [Self; 2] {
        [
            Self::Albedo(kind, shadowing),
            Self::MeanScale(kind, shadowing),
        ]
    }

    /// The tables a compensated interface of index ratio `eta` reads, from
    /// either side.
    pub fn of_interface(kind: NdfKind, shadowing: Shadowing, eta: f32) -> Vec<Self> {
        let albedos = DielectricAlbedoTable::nodes_read(eta)
            .map(|i| Self::DielectricAlbedo(kind, shadowing, i));
        let gains = slices_read(eta).map(|i| Self::DielectricMeanScale(kind, shadowing, i));
        albedos.chain(gains).collect()
    }

    /// True for a mean-scale table, which reads albedo tables as it is
    /// built: a caller building tables in parallel builds the albedos first
    /// and these next, so that no thread waits for another's albedo.
    pub fn reads_albedos(self) -> bool {
        matches!(self, Self::MeanScale(..) | Self::DielectricMeanScale(..))
    }

    /// Builds the table now, on this thread, unless it is built (the
    /// module docs give the cost); a call for a table another thread is
    /// building waits for it.
    pub fn build(self) {
        match self {
            Self::Albedo(kind, shadowing) => {
                albedo_table(kind, shadowing);
            }
            Self::MeanScale(kind, shadowing) => {
                mean_scale_table(kind, shadowing);
            }
            Self::DielectricAlbedo(kind, shadowing, i) => {
                dielectric_albedo_table(kind, shadowing).prepare_node(i);
            }
            Self::DielectricMeanScale(kind, shadowing, i) => {
                mean_scale_slice(kind, shadowing, i);
            }
        }
    }

    /// True once the table is built (never builds it).
    pub fn is_built(self) -> bool {
        match self {
            Self::Albedo(kind, shadowing) => albedo_table_is_built(kind, shadowing),
            Self::MeanScale(kind, shadowing) => mean_scale_table_is_built(kind, shadowing),
            Self::DielectricAlbedo(kind, shadowing, i) => {
                dielectric_albedo_table(kind, shadowing).node_is_built(i)
            }
            Self::DielectricMeanScale(kind, shadowing, i) => {
                mean_scale_slice_is_built(kind, shadowing, i)
            }
        }
    }
}

/// Builds now, on this thread, every energy table that `bsdf.regularized`
/// may read (none for a Lambertian lobe or a thin sheet), so that the first
/// regularization of the lobe does not pay for them (module docs: seconds
/// in a release build for a dielectric). Tables are shared by every lobe of
/// the same NDF and shadowing (and, for an interface, a nearby index ratio):
/// a renderer calls this for each material at start-up, in parallel if it
/// likes, or lists the tables with [`Bsdf::energy_tables`] and builds them
/// with [`EnergyTable::build`].
pub fn prepare_tables(bsdf: &Bsdf) {
    // On one thread the order does not matter: a gain table builds the
    // albedos it reads if they are not built yet.
    for table in bsdf.energy_tables() {
        table.build();
    }
}
