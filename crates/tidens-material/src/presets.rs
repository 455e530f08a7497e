use crate::error::MaterialError;
use crate::params::Material;

/// Default Young's modulus \[MPa\]: the value implied by the paper's creep
/// tolerance (2.3e-6 for 0.1 MPa), plausible for Ti-6Al-4V near 1293 K.
pub const DEFAULT_YOUNG_MPA: f64 = 4.35e4;
/// Default Poisson's ratio.
pub const DEFAULT_POISSON: f64 = 0.3;

/// The paper's six materials (docs/model.md section 1), steady creep `C q^n`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Preset {
    /// Ti-6Al-4V, isothermal creep at 1293 K (beta): C = 4.8e-7, n = 2.8.
    Ti64Creep1293K,
    /// Ti-6Al-4V, thermal cycling 1133-1293 K (transformation mismatch
    /// plasticity, period 191 s), cycle-averaged: C = 1.045e-5, n = 1. The law
    /// is linear only while stresses stay near the internal stress (7.4 MPa);
    /// contact stresses exceed it, a limitation the paper shares.
    Ti64Tmp1133To1293K,
    /// CP-Ti alpha at 1003 K: C = 1.29e-10, n = 4.3.
    CpTiAlpha1003K,
    /// CP-Ti alpha at 1073 K: C = 7.72e-10, n = 4.3.
    CpTiAlpha1073K,
    /// CP-Ti alpha at 1143 K: C = 3.86e-9, n = 4.3.
    CpTiAlpha1143K,
    /// CP-Ti beta at 1253 K: C = 6.74e-6, n = 4.3.
    CpTiBeta1253K,
}

impl Preset {
    /// Every preset, in the order of the table in docs/model.md.
    pub const ALL: [Preset; 6] = [
        Preset::Ti64Creep1293K,
        Preset::Ti64Tmp1133To1293K,
        Preset::CpTiAlpha1003K,
        Preset::CpTiAlpha1073K,
        Preset::CpTiAlpha1143K,
        Preset::CpTiBeta1253K,
    ];

    /// The command-line name, e.g. `ti64-creep-1293k`.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Ti64Creep1293K => "ti64-creep-1293k",
            Preset::Ti64Tmp1133To1293K => "ti64-tmp-1133-1293k",
            Preset::CpTiAlpha1003K => "cpti-alpha-1003k",
            Preset::CpTiAlpha1073K => "cpti-alpha-1073k",
            Preset::CpTiAlpha1143K => "cpti-alpha-1143k",
            Preset::CpTiBeta1253K => "cpti-beta-1253k",
        }
    }

    /// Looks a preset up by its command-line name.
    pub fn from_name(name: &str) -> Result<Preset, MaterialError> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
                MaterialError::UnknownPreset(name.to_string(), names.join(", "))
            })
    }

    /// Norton coefficient C [MPa^-n s^-1] and exponent n.
    pub fn creep_law(self) -> (f64, f64) {
        match self {
            Preset::Ti64Creep1293K => (4.8e-7, 2.8),
            Preset::Ti64Tmp1133To1293K => (1.045e-5, 1.0),
            Preset::CpTiAlpha1003K => (1.29e-10, 4.3),
            Preset::CpTiAlpha1073K => (7.72e-10, 4.3),
            Preset::CpTiAlpha1143K => (3.86e-9, 4.3),
            Preset::CpTiBeta1253K => (6.74e-6, 4.3),
        }
    }

    /// The preset with the default elastic constants (E = 43.5 GPa, nu = 0.3).
    pub fn material(self) -> Material {
        let (c, n) = self.creep_law();
        Material {
            young: DEFAULT_YOUNG_MPA,
            poisson: DEFAULT_POISSON,
            creep_c: c,
            creep_n: n,
        }
    }
}

/// Norton coefficient of transformation mismatch plasticity (linear in stress):
/// `C = (4/3) * 5n/(4n+1) * (dV/V) / dt_cycle / sigma0` [MPa^-1 s^-1], with `n`
/// the creep exponent of the phases, `dv_over_v` the transformation volume
/// change, `cycle_s` the full thermal cycle period \[s\] and `sigma0_mpa` the
/// internal stress \[MPa\] (docs/model.md section 1).
pub fn tmp_creep_coefficient(dv_over_v: f64, cycle_s: f64, sigma0_mpa: f64, n: f64) -> f64 {
    4.0 / 3.0 * 5.0 * n / (4.0 * n + 1.0) * dv_over_v / cycle_s / sigma0_mpa
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_list_the_choices() {
        for p in Preset::ALL {
            assert_eq!(Preset::from_name(p.name()).unwrap(), p);
        }
        let err = Preset::from_name("ti64").unwrap_err().to_string();
        assert!(
            err.contains("ti64-creep-1293k") && err.contains("cpti-beta-1253k"),
            "{err}"
        );
    }

    #[test]
    fn tmp_formula_matches_the_paper_coefficient_within_one_percent() {
        let c = tmp_creep_coefficient(0.0096, 191.0, 7.4, 2.8);
        let (paper, n) = Preset::Ti64Tmp1133To1293K.creep_law();
        assert_eq!(n, 1.0);
        assert!(
            (c / paper - 1.0).abs() < 0.01,
            "formula {c:e} vs the paper's {paper:e}"
        );
        assert!((c - 1.039e-5).abs() < 0.001e-5);
    }
}
