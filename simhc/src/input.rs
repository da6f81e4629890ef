//! Reading correspondences and trials from JSON with errors that say where.
//!
//! serde's derived readers report the first mismatch of the *outer* shape they tried ("invalid
//! type: map, expected a sequence at line 1 column 0" for a bearing of two numbers, once the
//! input may be either an object or a bare array). Here the document is parsed once into a
//! [`serde_json::Value`] and walked by hand, so that every error names its place: trial,
//! correspondence, field and component.
//!
//! ```text
//! correspondence 3, field `f`: expected an array of 3 numbers, got an array of 2
//! trial 12, field `rotation`, row 1: expected an array of 3 numbers, got a string
//! malformed JSON at line 4, column 17: expected value (NaN and Infinity are not JSON numbers; write them as finite numbers)
//! ```
//!
//! Non-finite values cannot occur in JSON; finite numbers outside what the solver accepts
//! (zero bearings, too few correspondences) are the solver's typed errors.

use crate::layout::{FieldKind, Layout};
use serde_json::Value;
use std::fmt;
use thiserror::Error;

/// A correspondence type read field by field: every field is a 3-vector.
pub trait VectorFields: Sized {
    /// Field names, in the order [`VectorFields::from_fields`] takes them.
    const FIELDS: &'static [&'static str];
    /// The record from its fields, in [`VectorFields::FIELDS`] order.
    fn from_fields(fields: &[[f64; 3]]) -> Self;
}

/// A trial (correspondences with a ground truth) read from JSON.
pub trait TrialFields: Sized {
    /// The correspondence type.
    type Correspondence: VectorFields;
    /// Whether the ground truth has a `scale` field.
    const HAS_SCALE: bool;
    /// The trial from its parts (`scale` is 1 without a scale field).
    fn from_parts(correspondences: Vec<Self::Correspondence>, rotation: [[f64; 3]; 3], translation: [f64; 3], scale: f64) -> Self;
}

/// Where in the document an error is.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Location {
    /// Index of the trial in a trials file.
    pub trial: Option<usize>,
    /// Index of the correspondence.
    pub correspondence: Option<usize>,
    /// The field name.
    pub field: Option<&'static str>,
    /// Row of a matrix field.
    pub row: Option<usize>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if let Some(t) = self.trial {
            parts.push(format!("trial {t}"));
        }
        if let Some(c) = self.correspondence {
            parts.push(format!("correspondence {c}"));
        }
        if let Some(name) = self.field {
            parts.push(format!("field `{name}`"));
        }
        if let Some(r) = self.row {
            parts.push(format!("row {r}"));
        }
        if parts.is_empty() {
            parts.push("document".to_string());
        }
        write!(f, "{}", parts.join(", "))
    }
}

/// Why a JSON input was rejected.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum InputError {
    /// Not JSON at all.
    #[error("malformed JSON at line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// serde_json's description, with a hint for `NaN` / `Infinity`.
        message: String,
    },
    /// JSON of the wrong shape at `at`.
    #[error("{at}: expected {expected}, got {got}")]
    Shape {
        /// Where.
        at: Location,
        /// What was expected there.
        expected: String,
        /// What was found (its JSON type, or an array's length).
        got: String,
    },
    /// A required field is absent.
    #[error("{at}: missing field `{field}`")]
    Missing {
        /// The object that lacks it.
        at: Location,
        /// The field.
        field: &'static str,
    },
    /// A field the format does not have (a misspelling, usually).
    #[error("{at}: unknown field `{field}`, expected one of {expected}")]
    Unknown {
        /// The object that has it.
        at: Location,
        /// The field.
        field: String,
        /// The fields of the format.
        expected: String,
    },
}

/// Correspondences from `{"correspondences": [...]}` or a bare array of them.
pub fn parse_correspondences<C: VectorFields>(text: &str) -> Result<Vec<C>, InputError> {
    let doc = parse(text)?;
    let at = Location::default();
    let list = match &doc {
        Value::Object(map) => {
            check_fields(map, &["correspondences"], &at)?;
            map.get("correspondences").ok_or(InputError::Missing { at: at.clone(), field: "correspondences" })?
        }
        other => other,
    };
    correspondences(list, &at)
}

/// Trials from a JSON array of `{"correspondences": [...], "rotation": [[..], [..], [..]],
/// "translation": [..]}` (plus `"scale"` where the problem has one).
pub fn parse_trials<T: TrialFields>(text: &str) -> Result<Vec<T>, InputError> {
    let doc = parse(text)?;
    let trials = doc.as_array().ok_or_else(|| shape(Location::default(), "an array of trials", &doc))?;
    let fields: &[&str] = if T::HAS_SCALE {
        &["correspondences", "rotation", "translation", "scale"]
    } else {
        &["correspondences", "rotation", "translation"]
    };
    trials
        .iter()
        .enumerate()
        .map(|(i, trial)| {
            let at = Location { trial: Some(i), ..Location::default() };
            let map = trial.as_object().ok_or_else(|| shape(at.clone(), "an object", trial))?;
            check_fields(map, fields, &at)?;
            let get = |field: &'static str| map.get(field).ok_or(InputError::Missing { at: at.clone(), field });
            let corrs = correspondences(get("correspondences")?, &at)?;
            let field_at = |field| Location { field: Some(field), ..at.clone() };
            let rows = get("rotation")?;
            let rows_list =
                rows.as_array().filter(|r| r.len() == 3).ok_or_else(|| shape(field_at("rotation"), "an array of 3 rows", rows))?;
            let mut rotation = [[0.0; 3]; 3];
            for (r, row) in rows_list.iter().enumerate() {
                rotation[r] = vector(row, Location { row: Some(r), ..field_at("rotation") })?;
            }
            let translation = vector(get("translation")?, field_at("translation"))?;
            let scale = if T::HAS_SCALE {
                let s = get("scale")?;
                s.as_f64().ok_or_else(|| shape(field_at("scale"), "a number", s))?
            } else {
                1.0
            };
            Ok(T::from_parts(corrs, rotation, translation, scale))
        })
        .collect()
}

/// The parameter vector of any declared problem from `{"correspondences": [{field: value, ..},
/// ..], "globals": {field: value, ..}}`, read through the problem's [`Layout`]
/// (`P::LAYOUT` of a `#[simhc_problem]` instance): exactly `layout.rows` correspondences with
/// every row field, and every global field (`"globals"` may be omitted when there are none).
/// Values by kind: a number (`Scalar`), an array of `n` numbers (`Vector(n)`, `Quat`), an array
/// of `r` rows of `c` numbers (`Matrix(r, c)`), the full symmetric `n x n` matrix (`Sym(n)`;
/// its upper triangle is used, and an asymmetric one is rejected).
pub fn parse_layout_params(layout: &Layout, text: &str) -> Result<Vec<f64>, InputError> {
    let (mut p, globals) = read_layout(layout, text, false)?;
    p.extend(globals);
    Ok(p)
}

/// [`parse_layout_params`] for at least `layout.rows` correspondences (a solve of more rows than
/// the data instance has, `simhc::solver::Solver::solve_rows`): the row numbers, row after row
/// in the layout's order, and the global numbers apart.
pub fn parse_layout_rows(layout: &Layout, text: &str) -> Result<(Vec<f64>, Vec<f64>), InputError> {
    read_layout(layout, text, true)
}

/// The row numbers and the global numbers of `text`: exactly `layout.rows` correspondences, or
/// at least that many when `more` is set.
fn read_layout(layout: &Layout, text: &str, more: bool) -> Result<(Vec<f64>, Vec<f64>), InputError> {
    let doc = parse(text)?;
    let root = Location::default();
    let map = doc.as_object().ok_or_else(|| shape(root.clone(), "an object with `correspondences` and `globals`", &doc))?;
    check_fields(map, &["correspondences", "globals"], &root)?;
    let mut p = Vec::with_capacity(layout.rows * layout.per_row);
    if layout.rows > 0 {
        let list = map.get("correspondences").ok_or(InputError::Missing { at: root.clone(), field: "correspondences" })?;
        let at = Location { field: Some("correspondences"), ..root.clone() };
        let items = list.as_array().ok_or_else(|| shape(at.clone(), "an array of correspondences", list))?;
        if items.len() != layout.rows && !(more && items.len() > layout.rows) {
            let expected = format!("{}{} correspondences", if more { "at least " } else { "" }, layout.rows);
            return Err(InputError::Shape { at, expected, got: format!("{}", items.len()) });
        }
        let fields: Vec<&str> = layout.row.iter().map(|f| f.name).collect();
        for (i, item) in items.iter().enumerate() {
            let at = Location { correspondence: Some(i), ..root.clone() };
            let obj = item.as_object().ok_or_else(|| shape(at.clone(), format!("an object with fields {}", names(&fields)), item))?;
            check_fields(obj, &fields, &at)?;
            for f in layout.row {
                let value = obj.get(f.name).ok_or(InputError::Missing { at: at.clone(), field: f.name })?;
                field_values(value, f.kind, Location { field: Some(f.name), ..at.clone() }, &mut p)?;
            }
        }
    } else if map.contains_key("correspondences") {
        return Err(InputError::Unknown {
            at: root,
            field: "correspondences".into(),
            expected: "`globals` (this problem has no rows)".into(),
        });
    }
    let mut g = Vec::with_capacity(layout.globals_len());
    if !layout.globals.is_empty() {
        let globals = map.get("globals").ok_or(InputError::Missing { at: root.clone(), field: "globals" })?;
        let at = Location { field: Some("globals"), ..root.clone() };
        let obj = globals.as_object().ok_or_else(|| shape(at.clone(), "an object", globals))?;
        let fields: Vec<&str> = layout.globals.iter().map(|f| f.name).collect();
        check_fields(obj, &fields, &at)?;
        for f in layout.globals {
            let value = obj.get(f.name).ok_or(InputError::Missing { at: at.clone(), field: f.name })?;
            field_values(value, f.kind, Location { field: Some(f.name), ..root.clone() }, &mut g)?;
        }
    }
    Ok((p, g))
}

/// Appends the scalars of one field of kind `kind` (see [`parse_layout_params`]).
fn field_values(value: &Value, field_kind: FieldKind, at: Location, out: &mut Vec<f64>) -> Result<(), InputError> {
    let matrix = |value: &Value, r: usize, c: usize| -> Result<Vec<Vec<f64>>, InputError> {
        let rows =
            value.as_array().filter(|rows| rows.len() == r).ok_or_else(|| shape(at.clone(), format!("an array of {r} rows"), value))?;
        rows.iter().enumerate().map(|(i, row)| numbers(row, c, &Location { row: Some(i), ..at.clone() })).collect()
    };
    match field_kind {
        FieldKind::Scalar => out.push(value.as_f64().ok_or_else(|| shape(at.clone(), "a number", value))?),
        FieldKind::Vector(n) => out.extend(numbers(value, n, &at)?),
        FieldKind::Quat => out.extend(numbers(value, 4, &at)?),
        FieldKind::Matrix(r, c) => out.extend(matrix(value, r, c)?.concat()),
        FieldKind::Sym(n) => {
            let m = matrix(value, n, n)?;
            for i in 0..n {
                for j in i..n {
                    let (a, b) = (m[i][j], m[j][i]);
                    if (a - b).abs() > 1e-12 * (1.0 + a.abs().max(b.abs())) {
                        return Err(InputError::Shape {
                            at: Location { row: Some(j), ..at },
                            expected: format!("a symmetric matrix (entry {j},{i} equal to {i},{j} = {a})"),
                            got: format!("{b}"),
                        });
                    }
                    out.push(a);
                }
            }
        }
    }
    Ok(())
}

fn parse(text: &str) -> Result<Value, InputError> {
    serde_json::from_str(text).map_err(|e| {
        let (line, column) = (e.line(), e.column());
        let mut message = e.to_string();
        // serde_json appends " at line L column C"; the variant carries them already.
        if let Some(cut) = message.rfind(" at line ") {
            message.truncate(cut);
        }
        let rest = text
            .lines()
            .nth(line.saturating_sub(1))
            .map(|l| l.chars().skip(column.saturating_sub(1)).collect::<String>())
            .unwrap_or_default();
        let rest = rest.trim_start().trim_start_matches('-');
        if rest.starts_with("NaN") || rest.starts_with("Infinity") || rest.starts_with("nan") || rest.starts_with("inf") {
            message.push_str(" (NaN and Infinity are not JSON numbers; every value must be a finite number)");
        }
        InputError::Syntax { line, column, message }
    })
}

fn correspondences<C: VectorFields>(list: &Value, at: &Location) -> Result<Vec<C>, InputError> {
    let field_at = Location { field: Some("correspondences"), ..at.clone() };
    let items = list.as_array().ok_or_else(|| shape(field_at, "an array of correspondences", list))?;
    items
        .iter()
        .enumerate()
        .map(|(i, item)| {
            let at = Location { correspondence: Some(i), ..at.clone() };
            let map = item.as_object().ok_or_else(|| shape(at.clone(), format!("an object with fields {}", names(C::FIELDS)), item))?;
            check_fields(map, C::FIELDS, &at)?;
            let fields = C::FIELDS
                .iter()
                .map(|&name| {
                    let value = map.get(name).ok_or(InputError::Missing { at: at.clone(), field: name })?;
                    vector(value, Location { field: Some(name), ..at.clone() })
                })
                .collect::<Result<Vec<_>, _>>()?;
            Ok(C::from_fields(&fields))
        })
        .collect()
}

fn vector(value: &Value, at: Location) -> Result<[f64; 3], InputError> {
    let v = numbers(value, 3, &at)?;
    Ok([v[0], v[1], v[2]])
}

/// An array of exactly `n` numbers at `at`.
fn numbers(value: &Value, n: usize, at: &Location) -> Result<Vec<f64>, InputError> {
    let expected = format!("an array of {n} numbers");
    let items = value.as_array().ok_or_else(|| shape(at.clone(), expected.clone(), value))?;
    if items.len() != n {
        return Err(InputError::Shape { at: at.clone(), expected, got: format!("an array of {}", items.len()) });
    }
    items
        .iter()
        .enumerate()
        .map(|(k, item)| {
            item.as_f64().ok_or_else(|| InputError::Shape {
                at: at.clone(),
                expected: expected.clone(),
                got: format!("{} at index {k}", kind(item)),
            })
        })
        .collect()
}

fn check_fields(map: &serde_json::Map<String, Value>, fields: &[&str], at: &Location) -> Result<(), InputError> {
    match map.keys().find(|k| !fields.contains(&k.as_str())) {
        Some(field) => Err(InputError::Unknown { at: at.clone(), field: field.clone(), expected: names(fields) }),
        None => Ok(()),
    }
}

fn names(fields: &[&str]) -> String {
    fields.iter().map(|f| format!("`{f}`")).collect::<Vec<_>>().join(", ")
}

fn shape(at: Location, expected: impl Into<String>, got: &Value) -> InputError {
    InputError::Shape { at, expected: expected.into(), got: kind(got).to_string() }
}

fn kind(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}
