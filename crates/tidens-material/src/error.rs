use thiserror::Error;

/// Bad material parameters or an impossible material-point state.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum MaterialError {
    /// A parameter outside its allowed range.
    #[error("{name} = {value}: must be {allowed}")]
    Parameter {
        name: &'static str,
        value: f64,
        allowed: &'static str,
    },
    /// An unknown preset name.
    #[error("unknown material preset '{0}': expected one of {1}")]
    UnknownPreset(String, String),
    /// The deformation gradient handed to the material is inverted or degenerate.
    #[error("deformation gradient with det F = {det_f:e} <= 0 (inverted material)")]
    Inverted { det_f: f64 },
}
