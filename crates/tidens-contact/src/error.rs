use thiserror::Error;

/// Bad contact set-up.
#[derive(Error, Debug, Clone, PartialEq)]
pub enum ContactError {
    #[error("{name} = {value}: must be {allowed}")]
    Parameter {
        name: &'static str,
        value: f64,
        allowed: &'static str,
    },
    #[error("contact surface: {0}")]
    Surface(String),
}
