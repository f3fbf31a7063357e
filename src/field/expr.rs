//! Expression fields: an [exmex] expression over `x`, `y`, `z` (world coordinates of the grid
//! point) and `t` (time), with exmex's float operators (`+ - * / ^`, `sin`, `cos`, `exp`,
//! `sqrt`, `abs`, `min`, `max`, `atan2`, ...) and constants (`PI`, `E`, `TAU`).
//!
//! Names are checked when the expression is compiled, so a misspelt function or a stray
//! variable is reported at load time rather than as a NaN grid.

use exmex::prelude::*;
use exmex::{FloatOpsFactory, MakeOperators};
use glam::DVec3;

use super::FieldError;

/// The variables an expression may use, in the order [`ExprSource::eval`] fills them.
const VARIABLES: [&str; 4] = ["x", "y", "z", "t"];

/// The longest `field.expression` read, in bytes.
pub const MAX_EXPRESSION_BYTES: usize = 4096;

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
        // The parser's cost grows faster than the text (100,000 nested sin( took 8 s, 300,000
        // over a minute) and every grid point evaluates every term: a bound before any work
        // (a `serve` state is parsed on a worker). Scene expressions are a line or two.
        if text.len() > MAX_EXPRESSION_BYTES {
            return Err(err(format!(
                "{} bytes, over the {MAX_EXPRESSION_BYTES} an expression may have (sample a \
                 longer formula into a raw or npy file)",
                text.len()
            )));
        }
        check_syntax(text).map_err(err)?;
        // exmex's message is not shown (see check_syntax).
        let expr = exmex::parse::<f64>(text).map_err(|_| {
            err("cannot parse: not an expression of numbers, x, y, z, t, constants, \
                 functions and the operators + - * / ^"
                .into())
        })?;
        let mut slots = Vec::new();
        for name in expr.var_names() {
            match VARIABLES.iter().position(|v| v == name) {
                Some(slot) => slots.push(slot),
                None => {
                    return Err(err(format!(
                        "unknown variable \"{}\" (the variables are x, y, z and t; \
                         constants are PI, E and TAU)",
                        crate::vocab::echo(name)
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

/// What the last token was, for [`check_syntax`]: what may follow it.
#[derive(Clone, Copy, PartialEq)]
enum Prev {
    /// The start, `(`, `,` or an operator: a value must come next.
    NeedValue,
    /// A function name: its argument must come next.
    Function,
    /// A number, variable, constant or `)`: an operator, `)` or `,` must come next.
    Value,
}

/// Checks the expression's shape before exmex sees it, and names the first mistake by its
/// character position (1-based). exmex's own messages print its tokens with Rust's `Debug`
/// (function addresses included), so none of them reaches a user: whatever this check lets
/// through that exmex still refuses gets a fixed sentence in [`ExprSource::parse`].
fn check_syntax(text: &str) -> Result<(), String> {
    let known = function_names();
    let chars: Vec<char> = text.chars().collect();
    let mut open: Vec<usize> = Vec::new();
    let mut prev = Prev::NeedValue;
    let mut i = 0;
    // A value at character `at` (1-based) where `prev` allows one.
    let value = |prev: Prev, at: usize, what: &str| -> Result<Prev, String> {
        match prev {
            Prev::Value => Err(format!(
                "cannot parse: {what} at character {at} follows a value without an operator \
                 between them"
            )),
            _ => Ok(Prev::Value),
        }
    };
    while i < chars.len() {
        let c = chars[i];
        let at = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c == '{' {
            // `{any name}` is one variable.
            let Some(close) = chars[i..].iter().position(|&c| c == '}') else {
                return Err(format!("cannot parse: \"{{\" at character {at} is never closed"));
            };
            prev = value(prev, at, "a variable")?;
            i += close + 1;
        } else if c.is_ascii_digit() || c == '.' {
            // A number. exmex reads no exponent (`1.5e-3` would be 1.5, the constant e, minus
            // 3): say so rather than let it fail on the pieces.
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    // Cut and escaped as every echoed value (a 4 KiB mantissa, a control char).
                    let mantissa: String = chars[start..i].iter().collect();
                    let mantissa = crate::vocab::echo(&mantissa);
                    return Err(format!(
                        "cannot parse: the number at character {at} has an exponent, which \
                         expressions do not read; write {mantissa} * 10^..."
                    ));
                }
            }
            prev = value(prev, at, "a number")?;
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let whole: String = chars[start..i].iter().collect();
            let name = crate::vocab::echo(&whole);
            let mut j = i;
            while j < chars.len() && chars[j].is_whitespace() {
                j += 1;
            }
            let called = j < chars.len() && chars[j] == '(';
            if known.contains(&whole.as_str()) {
                if prev == Prev::Value {
                    return Err(format!(
                        "cannot parse: function \"{name}\" at character {at} follows a value \
                         without an operator between them"
                    ));
                }
                prev = Prev::Function;
            } else if called {
                return Err(format!(
                    "unknown function \"{name}\" (functions: {})",
                    known.join(", ")
                ));
            } else {
                prev = value(prev, at, &format!("\"{name}\""))?;
            }
        } else if c == '(' {
            if prev == Prev::Value {
                return Err(format!(
                    "cannot parse: \"(\" at character {at} follows a value without an operator \
                     between them"
                ));
            }
            open.push(at);
            prev = Prev::NeedValue;
            i += 1;
        } else if c == ')' || c == ',' {
            if open.is_empty() {
                return Err(match c {
                    ')' => format!("cannot parse: \")\" at character {at} has no matching \"(\""),
                    _ => format!(
                        "cannot parse: \",\" at character {at} is outside a function's parentheses"
                    ),
                });
            }
            if prev != Prev::Value {
                return Err(format!(
                    "cannot parse: a value is missing before \"{c}\" at character {at}"
                ));
            }
            if c == ')' {
                open.pop();
                prev = Prev::Value;
            } else {
                prev = Prev::NeedValue;
            }
            i += 1;
        } else if "+-*/^".contains(c) {
            // `+` and `-` may also be signs, where a value is expected.
            let sign = c == '+' || c == '-';
            if prev != Prev::Value && !sign {
                return Err(format!(
                    "cannot parse: a value is missing before \"{c}\" at character {at}"
                ));
            }
            prev = Prev::NeedValue;
            i += 1;
        } else {
            return Err(format!(
                "cannot parse: unexpected character \"{}\" at character {at} (operators are \
                 + - * / ^)",
                c.escape_default()
            ));
        }
    }
    if let Some(at) = open.last() {
        return Err(format!("cannot parse: \"(\" at character {at} is never closed"));
    }
    match prev {
        Prev::Value => Ok(()),
        Prev::Function => {
            Err("cannot parse: the expression ends with a function and no argument".into())
        }
        Prev::NeedValue => {
            Err("cannot parse: the expression ends where a value is expected".into())
        }
    }
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

    /// exmex's messages carry its tokens' `Debug` output (function addresses): none may show.
    #[test]
    fn syntax_errors_are_one_clean_line_naming_the_place() {
        for (text, want) in [
            ("sin(x", "\"(\" at character 4 is never closed"),
            ("x)", "\")\" at character 2 has no matching \"(\""),
            ("x + * y", "a value is missing before \"*\" at character 5"),
            ("x +* y", "a value is missing before \"*\" at character 4"),
            ("x +", "ends where a value is expected"),
            ("2 x", "\"x\" at character 3 follows a value"),
            ("2 (y)", "\"(\" at character 3 follows a value"),
            ("()", "a value is missing before \")\" at character 2"),
            ("x, y", "\",\" at character 2 is outside"),
            ("x $ y", "unexpected character \"$\" at character 3"),
            ("sin", "ends with a function"),
            ("x sin(y)", "function \"sin\" at character 3"),
            ("min(x, )", "a value is missing before \")\" at character 8"),
            ("{x", "\"{\" at character 1 is never closed"),
            ("x + 1.5e-3", "the number at character 5 has an exponent"),
        ] {
            let e = ExprSource::parse(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: {e}");
            assert!(
                !e.contains("0x") && !e.contains("Operator") && !e.contains('\n'),
                "{text}: {e}"
            );
        }
        for ok in
            ["-x", "x * -y", "2^-x", "-(x + 1)", "sin(-x)", "1.5 * 10^-3 * x", "max(-x, +y)", "2*e"]
        {
            assert!(ExprSource::parse(ok).is_ok(), "{ok}");
        }
    }
}
