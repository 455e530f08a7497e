//! Integer arguments as the user types them.
//!
//! pyo3's own conversion of an `int` argument raises `OverflowError` for
//! `seed=2**70` and a `TypeError` that does not name the argument for
//! `seed=1.5` or `seed="a"`. Every integer a user types goes through
//! [`integer`] instead, so each of those names the argument, the value and
//! what is allowed, in the words of [`crate::errors::parameter_error`].

use crate::errors::parameter_error;
use pyo3::exceptions::{PyOverflowError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyInt};
use std::fmt::Display;
use std::ops::RangeInclusive;

/// `value` as an integer in `range`:
/// - `TypeError("seed = 1.5: must be an integer, not float")` unless it is
///   a Python `int` or has `__index__` (numpy's integers); a bool is not
///   one (True is a mistake, not 1), nor is an integral float such as 2.0;
/// - `ValueError("seed = 1180591620717411303424: must be an integer in
///   [0, 18446744073709551615]")` outside `range`, however large.
pub(crate) fn integer<T>(
    name: &str,
    value: &Bound<'_, PyAny>,
    range: RangeInclusive<T>,
) -> PyResult<T>
where
    T: Copy + Display + TryFrom<i128>,
    i128: TryFrom<T>,
{
    let out_of_range = |shown: &dyn Display| {
        parameter_error(
            name,
            shown,
            &format!("an integer in [{}, {}]", range.start(), range.end()),
        )
    };
    let int = as_int(name, value)?;
    // An int beyond 128 bits is out of every range here.
    let wide: i128 = match int.extract() {
        Ok(v) => v,
        Err(e) if e.is_instance_of::<PyOverflowError>(value.py()) => {
            return Err(out_of_range(&int));
        }
        Err(e) => return Err(e),
    };
    let within = i128::try_from(*range.start()).is_ok_and(|lo| lo <= wide)
        && i128::try_from(*range.end()).is_ok_and(|hi| wide <= hi);
    match T::try_from(wide) {
        Ok(v) if within => Ok(v),
        _ => Err(out_of_range(&wide)),
    }
}

/// [`integer`] for an optional argument: None stays None.
pub(crate) fn optional_integer<T>(
    name: &str,
    value: &Bound<'_, PyAny>,
    range: RangeInclusive<T>,
) -> PyResult<Option<T>>
where
    T: Copy + Display + TryFrom<i128>,
    i128: TryFrom<T>,
{
    if value.is_none() {
        Ok(None)
    } else {
        integer(name, value, range).map(Some)
    }
}

/// `value` as a Python int: itself, or what its `__index__` gives.
fn as_int<'py>(name: &str, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyInt>> {
    let type_name = value.get_type().name()?.to_string();
    let not_an_integer = || {
        let shown = value
            .repr()
            .map_or_else(|_| String::from("?"), |r| r.to_string());
        PyTypeError::new_err(format!(
            "{name} = {shown}: must be an integer, not {type_name}"
        ))
    };
    // numpy's bool has `__index__` too (`np.bool_`, `np.bool` in numpy 2).
    if value.is_instance_of::<PyBool>() || type_name == "bool_" || type_name == "bool" {
        return Err(not_an_integer());
    }
    if let Ok(int) = value.cast::<PyInt>() {
        return Ok(int.clone());
    }
    let index = value.py().import("operator")?.getattr("index")?;
    match index.call1((value,)) {
        Ok(int) => int.cast_into::<PyInt>().map_err(|_| not_an_integer()),
        Err(e) if e.is_instance_of::<PyTypeError>(value.py()) => Err(not_an_integer()),
        Err(e) => Err(e),
    }
}
