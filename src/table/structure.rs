//! The structure of a table file, checked before polars reads its cells: a header whose
//! names are unique, and, in CSV, every row with exactly as many fields as the header.
//!
//! polars would read either mistake without a word: a repeated column name is renamed
//! (`e_um_duplicated_0`) so the first column silently wins, and a row with fewer fields is
//! padded with empty cells, so a file cut in the middle of a row reads as a shorter row.
//! Here both are errors naming the file, and the row and line (a
//! [`TableError::Format`]) or the column ([`TableError::DuplicateColumn`]). Rows are
//! counted like polars counts them (a blank line is a row, left to the cell checks), so
//! the row numbers agree with every later message; the line is where the row starts.
//!
//! The CSV scan reads the file once, in 64 KiB buffers, line by line; quotes follow RFC
//! 4180 (a field in double quotes may hold commas and line breaks, `""` is a quote). It
//! also names the row of invalid UTF-8, which polars reports without one.
//!
//! Parquet files carry a schema: a repeated name is refused from it. A column of a type
//! the reader cannot convert (decimal, dates, narrow integers, lists…: polars was built
//! without those types and would panic on them) is left out of the read, so a table with
//! an unused column of any type reads; a reader that needs such a column gets an error
//! naming it and its type.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use std::panic::AssertUnwindSafe;
use std::sync::Once;
use std::sync::atomic::{AtomicUsize, Ordering};

use polars::prelude::{ArrowDataType, DataFrame, ParquetReader, SerReader};

use super::TableError;
use super::frame::format_err;
use crate::base::FileOp;
use crate::base::io_err;

/// Refuses a repeated name among `names` (the first repeated one, with its count).
fn unique_names<'a>(path: &Path, names: impl Iterator<Item = &'a str>) -> Result<(), TableError> {
    let mut seen: BTreeMap<&str, usize> = BTreeMap::new();
    let mut order = Vec::new();
    for n in names {
        let c = seen.entry(n).or_insert(0);
        if *c == 0 {
            order.push(n);
        }
        *c += 1;
    }
    if let Some(n) = order.into_iter().find(|n| seen[n] > 1) {
        return Err(TableError::DuplicateColumn {
            path: path.to_path_buf(),
            column: n.to_string(),
            count: seen[n],
        });
    }
    Ok(())
}

/// Splits one CSV record (without its line break) into fields, honouring quotes.
fn split_fields(record: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = record.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut field)),
            c => field.push(c),
        }
    }
    out.push(field);
    out
}

/// Checks a CSV file's header names and field counts (see the module docs).
pub(crate) fn check_csv(path: &Path) -> Result<(), TableError> {
    let file = File::open(path).map_err(io_err(path, FileOp::Read))?;
    let mut reader = BufReader::with_capacity(1 << 16, file);
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    // The record being read: its first line, its field count so far, inside quotes.
    let mut start_line = 0usize;
    let mut fields = 0usize;
    let mut quoted = false;
    let mut blank = true;
    let mut expected: Option<usize> = None;
    let mut header = String::new();
    let mut row = 0usize;
    loop {
        buf.clear();
        let n = reader
            .read_until(b'\n', &mut buf)
            .map_err(io_err(path, FileOp::Read))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let text = std::str::from_utf8(&buf).map_err(|_| TableError::NotUtf8 {
            path: path.to_path_buf(),
            row: if expected.is_some() { row + 1 } else { 0 },
            line: line_no,
        })?;
        if !quoted {
            start_line = line_no;
            fields = 1;
            blank = true;
        }
        for c in text.bytes() {
            match c {
                b'"' => {
                    quoted = !quoted;
                    blank = false;
                }
                b',' if !quoted => {
                    fields += 1;
                    blank = false;
                }
                b'\r' | b'\n' | b' ' | b'\t' => {}
                _ => blank = false,
            }
        }
        if expected.is_none() {
            header.push_str(text);
        }
        if quoted {
            continue; // a quoted field runs on over the line break
        }
        match expected {
            None => {
                let h = header
                    .trim_start_matches('\u{feff}')
                    .trim_end_matches(['\r', '\n']);
                let names: Vec<String> = split_fields(h)
                    .into_iter()
                    .map(|s| s.trim().to_string())
                    .collect();
                unique_names(path, names.iter().map(String::as_str))?;
                expected = Some(fields);
            }
            Some(want) => {
                row += 1;
                if !blank && fields != want {
                    return Err(format_err(
                        path,
                        format!(
                            "row {row} (line {start_line}) has {fields} fields, the header has {want}"
                        ),
                    ));
                }
            }
        }
    }
    if quoted {
        return Err(format_err(
            path,
            format!("a quoted field opened on line {start_line} is never closed"),
        ));
    }
    Ok(())
}

/// Reads the data of a Parquet file whose schema [`parquet_reader`] checked, through
/// [`guarded`]: polars' page decoder asserts on some damaged pages (issue 17's campaign:
/// four flipped bits gave `assertion failed: start + length <= self.bytes.len()` in a
/// polars worker) where it should return an error.
pub(crate) fn finish_parquet(
    path: &Path,
    reader: ParquetReader<File>,
) -> Result<DataFrame, TableError> {
    guarded(path, "a page cannot be decoded", || reader.finish())
}

/// Runs a polars Parquet call, turning a panic inside polars into the error naming the
/// file (`damaged Parquet data: {what}`), its message kept off stderr (see
/// [`quiet_decoder_panics`]). polars panics on some damaged files where it should return
/// an error: in the page decoder, and in the footer's Thrift decoder (`thrift bool field`
/// on three flipped bits, found by the campaign's seed 19).
pub(crate) fn guarded<T>(
    path: &Path,
    what: &str,
    call: impl FnOnce() -> polars::prelude::PolarsResult<T>,
) -> Result<T, TableError> {
    quiet_decoder_panics();
    DECODING.fetch_add(1, Ordering::SeqCst);
    let result = std::panic::catch_unwind(AssertUnwindSafe(call));
    DECODING.fetch_sub(1, Ordering::SeqCst);
    match result {
        Ok(r) => r.map_err(|e| format_err(path, e)),
        Err(_) => Err(format_err(path, format!("damaged Parquet data: {what}"))),
    }
}

/// Parquet decodes under way (the panic hook's test).
static DECODING: AtomicUsize = AtomicUsize::new(0);

/// Installs, once, a panic hook that stays silent about a panic inside polars while a
/// [`finish_parquet`] is under way (it is caught and reported as an error naming the
/// file) and hands every other panic to the hook that was there before.
fn quiet_decoder_panics() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let in_polars = info.location().is_some_and(|l| l.file().contains("polars"));
            if !(in_polars && DECODING.load(Ordering::SeqCst) > 0) {
                previous(info);
            }
        }));
    });
}

/// Whether polars, as built here, reads a Parquet column of this Arrow type into numbers or
/// text (the narrow integer types, dates, decimals, lists and structs it does not: issue
/// 28 found "cannot create series from UInt8").
fn readable(dtype: &ArrowDataType) -> bool {
    use ArrowDataType as T;
    matches!(
        dtype,
        T::Boolean
            | T::Int32
            | T::Int64
            | T::UInt32
            | T::UInt64
            | T::Float32
            | T::Float64
            | T::Utf8
            | T::LargeUtf8
            | T::Utf8View
    )
}

/// Opens a Parquet file and checks its schema (see the module docs): repeated names are
/// refused; columns of a type polars cannot read are left out of the read (an unused
/// `measured_on` date or `operator_id` byte is a normal column of a lab's table), and a
/// reader that needs one is told its type by [`unreadable_type`].
pub(crate) fn parquet_reader(path: &Path) -> Result<ParquetReader<File>, TableError> {
    let file = File::open(path).map_err(io_err(path, FileOp::Read))?;
    let mut reader = ParquetReader::new(file);
    let schema = guarded(path, "the footer (file metadata) cannot be decoded", || {
        reader.schema()
    })?;
    unique_names(path, schema.iter_values().map(|f| f.name.as_str()))?;
    if schema.iter_values().all(|f| readable(f.dtype())) {
        return Ok(reader);
    }
    let keep: Vec<String> = schema
        .iter_values()
        .filter(|f| readable(f.dtype()))
        .map(|f| f.name.to_string())
        .collect();
    Ok(reader.with_columns(Some(keep)))
}

/// The Arrow type of column `name` of the Parquet file at `path` when it is one that
/// [`parquet_reader`] leaves out (for the message of a reader that needs the column).
pub(crate) fn unreadable_type(path: &Path, name: &str) -> Option<String> {
    let mut reader = ParquetReader::new(File::open(path).ok()?);
    let schema = guarded(path, "the footer", || reader.schema()).ok()?;
    schema
        .iter_values()
        .find(|f| f.name.as_str() == name && !readable(f.dtype()))
        .map(|f| format!("{:?}", f.dtype()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(text: &str) -> Result<(), TableError> {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("t.csv");
        std::fs::write(&p, text).expect("write");
        check_csv(&p)
    }

    #[test]
    fn a_repeated_column_name_is_refused_by_name() {
        let e = csv("x_mm,y_mm,z_mm,e_um,e_um\n0,0,0,1,2\n").expect_err("refused");
        assert!(
            matches!(&e, TableError::DuplicateColumn { column, count: 2, .. } if column == "e_um"),
            "{e}"
        );
        // Quoted names are names too.
        let e = csv("\"x_mm\",x_mm\n1,2\n").expect_err("refused");
        assert!(matches!(e, TableError::DuplicateColumn { .. }), "{e}");
    }

    #[test]
    fn rows_with_too_few_or_too_many_fields_are_named() {
        let e = csv("a,b,c\n1,2,3\n4,5\n").expect_err("refused");
        assert!(matches!(e, TableError::Format { .. }), "{e}");
        assert!(
            e.to_string()
                .ends_with("row 2 (line 3) has 2 fields, the header has 3"),
            "{e}"
        );
        let e = csv("a,b\n1,2,3\n").expect_err("refused");
        assert!(e.to_string().contains("row 1 (line 2) has 3 fields"), "{e}");
        // A quoted line break: the row after it starts on line 4.
        let e = csv("a,b\n\"x\ny\",1\n2\n").expect_err("refused");
        assert!(e.to_string().contains("row 2 (line 4) has 1 fields"), "{e}");
    }

    #[test]
    fn quotes_blank_lines_and_crlf_are_structure_not_damage() {
        csv("a,b\r\n\"1,5\",2\r\n\"multi\nline\",3\r\n\r\n").expect("well formed");
        csv("a,b\n1,2").expect("no final line break");
        let e = csv("a,b\n\"1,2\n").expect_err("unclosed quote");
        assert!(e.to_string().contains("never closed"), "{e}");
    }

    #[test]
    fn invalid_utf8_names_its_line() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("t.csv");
        std::fs::write(&p, b"a,b\n1,2\n3,\xff\n").expect("write");
        let e = check_csv(&p).expect_err("refused");
        assert!(
            matches!(
                e,
                TableError::NotUtf8 {
                    row: 2,
                    line: 3,
                    ..
                }
            ),
            "{e}"
        );
    }
}
