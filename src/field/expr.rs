//! Expression fields: an [exmex] expression over `x`, `y`, `z` (world coordinates of the grid
//! point) and `t` (time), with exmex's float operators (`+ - * / ^`, `sin`, `cos`, `exp`,
//! `sqrt`, `abs`, `min`, `max`, `atan2`, ...) and constants (`PI`, `E`, `TAU`).
//!
//! Names are checked when the expression is compiled, so a misspelt function or a stray
//! variable is reported at load time rather than as a NaN grid.

use exmex::prelude::*;
use exmex::{FloatOpsFactory, MakeOperators};
use glam::DVec3;

use super::error::one_line;
use super::FieldError;

/// The variables an expression may use, in the order [`ExprSource::eval`] fills them.
const VARIABLES: [&str; 4] = ["x", "y", "z", "t"];

/// A compiled expression field.
#[derive(Clone, Debug)]
pub struct ExprSource {
    /// The expression as written.
    pub text: String,
    /// Boxed: exmex keeps its operators inline, some 20 KB.
    expr: Box<FlatEx<f64>>,
    /// For each of exmex's variables (alphabetical), its index in `VARIABLES`.
    slots: Vec<usize>,
}

impl PartialEq for ExprSource {
    fn eq(&self, other: &Self) -> bool {
        self.text == other.text
    }
}

impl ExprSource {
    /// Compiles `text`; unknown functions and variables other than `x`, `y`, `z`, `t` are errors.
    pub fn parse(text: &str) -> Result<ExprSource, FieldError> {
        let err = |message: String| FieldError::Expr { text: text.to_string(), message };
        if text.trim().is_empty() {
            return Err(err("the expression is empty".into()));
        }
        check_functions(text).map_err(err)?;
        let expr = exmex::parse::<f64>(text)
            .map_err(|e| err(format!("cannot parse: {}", one_line(&e.to_string()))))?;
        let mut slots = Vec::new();
        for name in expr.var_names() {
            match VARIABLES.iter().position(|v| v == name) {
                Some(slot) => slots.push(slot),
                None => {
                    return Err(err(format!(
                        "unknown variable \"{name}\" (the variables are x, y, z and t; \
                         constants are PI, E and TAU)"
                    )))
                }
            }
        }
        Ok(ExprSource { text: text.to_string(), expr: Box::new(expr), slots })
    }

    /// Whether the expression uses `t`.
    pub fn uses_time(&self) -> bool {
        self.slots.contains(&3)
    }

    /// The value at world point `p` and time `t` (NaN if exmex fails to evaluate).
    pub fn eval(&self, p: DVec3, t: f64) -> f64 {
        let all = [p.x, p.y, p.z, t];
        let mut vars = [0.0; 4];
        for (v, &slot) in vars.iter_mut().zip(&self.slots) {
            *v = all[slot];
        }
        self.expr.eval(&vars[..self.slots.len()]).unwrap_or(f64::NAN)
    }
}

/// Names of exmex's float functions (unary and binary operators written with letters).
fn function_names() -> Vec<&'static str> {
    FloatOpsFactory::<f64>::make()
        .iter()
        .filter(|op| {
            (op.has_unary() || op.has_bin()) && op.repr().chars().all(char::is_alphanumeric)
        })
        .map(|op| op.repr())
        .collect()
}

/// Fails on the first identifier called like a function that exmex does not know
/// (exmex's own message for `foo(x)` does not name the function).
fn check_functions(text: &str) -> Result<(), String> {
    let known = function_names();
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '{' {
            // `{any name}` is one variable.
            while i < chars.len() && chars[i] != '}' {
                i += 1;
            }
            i += 1;
        } else if c.is_ascii_digit() || c == '.' {
            // A number, with an optional exponent (`1.5e-3`).
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    i = j;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let name: String = chars[start..i].iter().collect();
            let mut j = i;
            while j < chars.len() && chars[j].is_whitespace() {
                j += 1;
            }
            if j < chars.len() && chars[j] == '(' && !known.contains(&name.as_str()) {
                return Err(format!(
                    "unknown function \"{name}\" (functions: {})",
                    known.join(", ")
                ));
            }
        } else {
            i += 1;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evaluates_with_variables_in_any_order() {
        let e = ExprSource::parse("sin(3*x)*cos(3*y) + z - 0.2*t").unwrap();
        let p = DVec3::new(0.1, 0.2, 0.3);
        let want = (0.3f64).sin() * (0.6f64).cos() + 0.3 - 0.2 * 1.5;
        assert!((e.eval(p, 1.5) - want).abs() < 1e-12);
        assert!(e.uses_time());
        let e = ExprSource::parse("z - y + 0.2*x + PI").unwrap();
        assert!(!e.uses_time());
        let want = 0.3 - 0.2 + 0.2 * 0.1 + std::f64::consts::PI;
        assert!((e.eval(p, 7.0) - want).abs() < 1e-12);
        assert_eq!(ExprSource::parse("2.5").unwrap().eval(p, 0.0), 2.5);
    }

    #[test]
    fn names_unknown_functions_and_variables() {
        let e = ExprSource::parse("foo(x) + 1").unwrap_err().to_string();
        assert!(e.contains("unknown function \"foo\""), "{e}");
        let e = ExprSource::parse("x + w").unwrap_err().to_string();
        assert!(e.contains("unknown variable \"w\""), "{e}");
        let e = ExprSource::parse("sin(x").unwrap_err().to_string();
        assert!(e.contains("cannot parse"), "{e}");
        assert!(ExprSource::parse("atan2(x, y) + max(x, z) + abs (t)").is_ok());
    }
}
