//! The last guard before a report or JSON document leaves errmap: no NaN or ±inf.
//!
//! The readers refuse non-finite and out-of-range values at the door, so a NaN at a
//! writer is a bug in a computation. Left alone it would be written silently wrong:
//! `serde_json` turns NaN and ±inf into `null` (a missing value, not an error), and
//! `format!` prints `NaN` or `inf` into a Markdown table. These checks refuse instead,
//! with [`ReportError::NonFinite`] naming the file (or `stdout`) and where the number sits
//! (a JSON path such as `rows[2].rms_um`, or a Markdown line), and nothing is written.
//!
//! - [`check_json`] walks any `Serialize` value (the same walk `serde_json` makes) and
//!   names the first non-finite `f64`/`f32` by its path.
//! - [`check_markdown`] looks for the words Rust's formatting gives a non-finite number
//!   (`NaN`, `inf`, `-inf`) outside code spans (file names and commands are quoted as
//!   code, so a file called `inf.csv` is not mistaken for a number).

use std::fmt::Display;
use std::path::Path;

use serde::ser::{self, Serialize};

use super::ReportError;

/// Refuses `value` when any number in it is NaN or ±inf; `path` names the output.
pub fn check_json<T: Serialize + ?Sized>(path: &Path, value: &T) -> Result<(), ReportError> {
    let mut walk = Walk::default();
    match value.serialize(&mut walk) {
        Ok(()) => Ok(()),
        Err(Found(Some((at, v)))) => Err(ReportError::NonFinite {
            path: path.to_path_buf(),
            at: if at.is_empty() {
                "the document".into()
            } else {
                at
            },
            value: v,
        }),
        // A value that cannot be serialized fails at the writer with serde_json's words.
        Err(Found(None)) => Ok(()),
    }
}

/// Refuses Markdown holding a non-finite number (see the module docs).
pub(crate) fn check_markdown(path: &Path, md: &str) -> Result<(), ReportError> {
    for (k, line) in md.lines().enumerate() {
        // Outside code spans: the even-numbered pieces between backticks.
        for piece in line.split('`').step_by(2) {
            let words = piece.split(|c: char| !(c.is_ascii_alphanumeric() || c == '.'));
            if let Some(w) = words.into_iter().find(|w| matches!(*w, "NaN" | "inf")) {
                return Err(ReportError::NonFinite {
                    path: path.to_path_buf(),
                    at: format!("line {}", k + 1),
                    value: if w == "NaN" { f64::NAN } else { f64::INFINITY },
                });
            }
        }
    }
    Ok(())
}

/// The error of the walk: the first non-finite number (its path and value), or `None`
/// for a custom error raised by a `Serialize` impl.
#[derive(Debug)]
struct Found(Option<(String, f64)>);

impl Display for Found {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Some((at, v)) => write!(f, "{v} at {at}"),
            None => f.write_str("not serializable"),
        }
    }
}

impl std::error::Error for Found {}

impl ser::Error for Found {
    fn custom<M: Display>(_: M) -> Self {
        Found(None)
    }
}

/// The serializer that walks a value, keeping the path to where it is.
#[derive(Default)]
struct Walk {
    path: Vec<String>,
}

impl Walk {
    fn float(&self, v: f64) -> Result<(), Found> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(Found(Some((self.path.concat(), v))))
        }
    }

    /// Walks `value` under the path segment `seg`.
    fn under<T: Serialize + ?Sized>(&mut self, seg: String, value: &T) -> Result<(), Found> {
        self.path.push(seg);
        let r = value.serialize(&mut *self);
        self.path.pop();
        r
    }

    fn field(&self, name: &str) -> String {
        if self.path.is_empty() {
            name.to_string()
        } else {
            format!(".{name}")
        }
    }
}

/// The compound state: how many elements so far, and the key of the next map value.
struct Compound<'a> {
    walk: &'a mut Walk,
    index: usize,
    key: String,
}

impl<'a> Compound<'a> {
    fn new(walk: &'a mut Walk) -> Self {
        Compound {
            walk,
            index: 0,
            key: String::new(),
        }
    }

    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Found> {
        let seg = format!("[{}]", self.index);
        self.index += 1;
        self.walk.under(seg, value)
    }
}

macro_rules! ok {
    ($($name:ident($($t:ty),*);)*) => {
        $(fn $name(self, $(_: $t),*) -> Result<(), Found> { Ok(()) })*
    };
}

/// The serializer's methods that open a sequence, a map or a struct: each walks into a
/// [`Compound`].
macro_rules! compound {
    ($($name:ident($($t:ty),*);)*) => {
        $(fn $name(self, $(_: $t),*) -> Result<Compound<'a>, Found> { Ok(Compound::new(self)) })*
    };
}

impl<'a> ser::Serializer for &'a mut Walk {
    type Ok = ();
    type Error = Found;
    type SerializeSeq = Compound<'a>;
    type SerializeTuple = Compound<'a>;
    type SerializeTupleStruct = Compound<'a>;
    type SerializeTupleVariant = Compound<'a>;
    type SerializeMap = Compound<'a>;
    type SerializeStruct = Compound<'a>;
    type SerializeStructVariant = Compound<'a>;

    ok! {
        serialize_bool(bool);
        serialize_i8(i8);
        serialize_i16(i16);
        serialize_i32(i32);
        serialize_i64(i64);
        serialize_u8(u8);
        serialize_u16(u16);
        serialize_u32(u32);
        serialize_u64(u64);
        serialize_char(char);
        serialize_str(&str);
        serialize_bytes(&[u8]);
        serialize_none();
        serialize_unit();
        serialize_unit_struct(&'static str);
        serialize_unit_variant(&'static str, u32, &'static str);
    }

    fn serialize_f32(self, v: f32) -> Result<(), Found> {
        self.float(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), Found> {
        self.float(v)
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), Found> {
        value.serialize(self)
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), Found> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), Found> {
        let seg = self.field(variant);
        self.under(seg, value)
    }
    compound! {
        serialize_seq(Option<usize>);
        serialize_tuple(usize);
        serialize_tuple_struct(&'static str, usize);
        serialize_tuple_variant(&'static str, u32, &'static str, usize);
        serialize_map(Option<usize>);
        serialize_struct(&'static str, usize);
        serialize_struct_variant(&'static str, u32, &'static str, usize);
    }
}

macro_rules! elements {
    ($($trait:ident :: $method:ident),*) => {
        $(impl ser::$trait for Compound<'_> {
            type Ok = ();
            type Error = Found;
            fn $method<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Found> {
                self.element(value)
            }
            fn end(self) -> Result<(), Found> {
                Ok(())
            }
        })*
    };
}

elements!(
    SerializeSeq::serialize_element,
    SerializeTuple::serialize_element,
    SerializeTupleStruct::serialize_field,
    SerializeTupleVariant::serialize_field
);

macro_rules! fields {
    ($($trait:ident),*) => {
        $(impl ser::$trait for Compound<'_> {
            type Ok = ();
            type Error = Found;
            fn serialize_field<T: Serialize + ?Sized>(
                &mut self,
                key: &'static str,
                value: &T,
            ) -> Result<(), Found> {
                let seg = self.walk.field(key);
                self.walk.under(seg, value)
            }
            fn end(self) -> Result<(), Found> {
                Ok(())
            }
        })*
    };
}

fields!(SerializeStruct, SerializeStructVariant);

impl ser::SerializeMap for Compound<'_> {
    type Ok = ();
    type Error = Found;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), Found> {
        // Keys are names (strings) in every errmap document; a number key is shown as such.
        self.key = serde_json::to_value(key)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string).or(Some(v.to_string())))
            .unwrap_or_default();
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Found> {
        let seg = self.walk.field(&self.key);
        self.walk.under(seg, value)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Row {
        method: &'static str,
        rms_um: f64,
        sigmas: Vec<Option<f64>>,
    }

    #[derive(serde::Serialize)]
    struct Doc {
        rows: Vec<Row>,
        extra: std::collections::BTreeMap<String, (f32, f64)>,
    }

    fn doc() -> Doc {
        Doc {
            rows: vec![
                Row {
                    method: "a",
                    rms_um: 1.0,
                    sigmas: vec![None, Some(0.5)],
                },
                Row {
                    method: "b",
                    rms_um: 2.0,
                    sigmas: vec![Some(0.1), None, Some(0.2)],
                },
            ],
            extra: [("k".to_string(), (1.0, 2.0))].into_iter().collect(),
        }
    }

    #[test]
    fn a_finite_document_passes_and_each_nan_is_named_by_its_path() {
        let p = Path::new("out.json");
        check_json(p, &doc()).expect("all finite");
        let mut d = doc();
        d.rows[1].sigmas[2] = Some(f64::NAN);
        let e = check_json(p, &d).expect_err("refused");
        assert!(
            matches!(&e, ReportError::NonFinite { at, .. } if at == "rows[1].sigmas[2]"),
            "{e}"
        );
        let mut d = doc();
        d.extra.insert("k".into(), (1.0, f64::NEG_INFINITY));
        let e = check_json(p, &d).expect_err("refused");
        assert!(
            matches!(&e, ReportError::NonFinite { at, .. } if at == "extra.k[1]"),
            "{e}"
        );
        let e = check_json(p, &[1.0, f64::INFINITY]).expect_err("refused");
        assert!(
            matches!(&e, ReportError::NonFinite { at, .. } if at == "[1]"),
            "{e}"
        );
        // serde_json::Value holds no NaN (it makes null), so a Value always passes.
        check_json(p, &serde_json::json!({"a": [1.0, null]})).expect("finite");
    }

    #[test]
    fn markdown_with_a_formatted_nan_or_inf_is_refused_but_not_a_code_span() {
        let p = Path::new("report.md");
        let ok = "# Report\n\n| a | b |\n|---|---|\n| 1.5 | -2e-3 |\n\nSee `inf.csv` and `NaN`; information.\n";
        check_markdown(p, ok).expect("finite");
        for bad in [
            format!("| {:.3} |", f64::NAN),
            format!("x {:.1} y", f64::NEG_INFINITY),
        ] {
            let md = format!("{ok}{bad}\n");
            let e = check_markdown(p, &md).expect_err("refused");
            assert!(
                matches!(&e, ReportError::NonFinite { at, .. } if at == "line 8"),
                "{e}"
            );
        }
    }
}
