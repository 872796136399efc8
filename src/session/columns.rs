//! Session rows held column by column, and their Parquet encoding row group by row group.
//!
//! The decoder hands rows over one at a time; a table is written by column. [`Columns`]
//! takes each row's fields straight into one vector per column (what polars and Parquet
//! hold), so a batch needs no row-to-column pass and no per-row allocation, and its
//! vectors are kept from batch to batch: after the first batch a long replay touches no
//! fresh memory. [`Columns::take_frame`] makes the same columns a polars `DataFrame` (CSV
//! tables, and every caller that wants a frame).
//!
//! **Parquet.** [`ParquetSink`] writes each batch as one row group through polars' own
//! Parquet writer (`polars-parquet`, the crate behind polars' `ParquetWriter`), choosing
//! the encoding per column instead of polars' one rule for all (try a dictionary, and for
//! floats decide by a HyperLogLog estimate of the cardinality over the whole column):
//! - `sample` is a counter: delta encoding (`DELTA_BINARY_PACKED`), a few bits a row;
//! - `run`, `direction`, `target`, `flags` are small integers: a dictionary (polars finds
//!   their distinct values from their min–max range, without hashing);
//! - every float column, and `axis`, plain (`PLAIN`): the measured ones (times, positions,
//!   lengths, errors) take nearly a distinct value a row, where a dictionary only costs;
//!   the slow ones (feed, air and material temperatures) repeat a value for thousands of
//!   rows, which the page compression folds to almost nothing anyway.
//!
//! Pages are compressed with zstd at level 1 (the fastest of zstd's standard levels;
//! polars' default is 3) through one zstd context kept for the whole file ([`Zstd`]):
//! polars' `Compressor` makes a new context for every page, a few hundred kB allocated and
//! cleared 19 times a row group. Pages carry null counts, with min and max for the key columns
//! (run, sample, time, axis, direction, target, flags; see [`MIN_MAX`]). The file is standard Parquet with polars' own Arrow
//! schema key, read back by polars (and by any Parquet reader) like the ones
//! `ParquetWriter` writes; the encodings are the Parquet format's own.
//!
//! Measured on a generated 203 MB capture, one core of this machine
//! (`docs/performance.md`, "Long captures in constant memory", has the figures and the
//! command).

use std::io::Write;

use errmap_drivers::SessionRow;
use errmap_drivers::frame::Axis as WireAxis;
use polars::prelude::*;
use polars_arrow::array::{Array, MutableBinaryViewArray, PrimitiveArray};
use polars_arrow::bitmap::{Bitmap, MutableBitmap};
use polars_arrow::datatypes::ArrowDataType;
use polars_parquet::parquet::CowBuffer;
use polars_parquet::parquet::compression::Compression;
use polars_parquet::parquet::page::{
    CompressedDataPage, CompressedDictPage, CompressedPage, DataPageHeader, Page,
};
use polars_parquet::write::{
    CompressionOptions, DynIter, DynStreamingIterator, Encoding, FallibleStreamingIterator,
    FileWriter, StatisticsOptions, Version, WriteOptions, ZstdLevel, array_to_columns,
};

/// An optional float column: values (0 where missing) and the rows where one is missing
/// (rare: before the first MARK or ENV), so that a row costs one push.
#[derive(Debug, Default)]
struct Optional {
    values: Vec<f64>,
    missing: Vec<usize>,
}

impl Optional {
    fn push(&mut self, v: Option<f64>) {
        match v {
            Some(v) => self.values.push(v),
            None => {
                self.missing.push(self.values.len());
                self.values.push(0.0);
            }
        }
    }

    /// The validity mask, `None` when every value is present.
    fn validity(&self) -> Option<Bitmap> {
        if self.missing.is_empty() {
            return None;
        }
        let mut present = MutableBitmap::from_len_set(self.values.len());
        for &i in &self.missing {
            present.set(i, false);
        }
        Some(present.freeze())
    }
}

/// A batch of session rows as columns, in `SessionRow::COLUMNS` order (see the module
/// docs).
#[derive(Debug, Default)]
pub(crate) struct Columns {
    run: Vec<i64>,
    sample: Vec<i64>,
    t_s: Vec<f64>,
    axis: Vec<WireAxis>,
    direction: Vec<i64>,
    feed_mm_s: Optional,
    target: Vec<i64>,
    x_mm: Optional,
    y_mm: Optional,
    z_mm: Optional,
    scale_mm: Vec<f64>,
    laser_mm: Vec<f64>,
    error_um: Vec<f64>,
    air_temp_c: Optional,
    air_pressure_hpa: Optional,
    air_rh_pct: Optional,
    scale_temp_c: Optional,
    part_temp_c: Optional,
    flags: Vec<i64>,
    /// Vectors back from the last batch's arrays, for the next batch's columns.
    spare: Spare,
}

/// Emptied column vectors, kept for reuse.
#[derive(Debug, Default)]
struct Spare {
    floats: Vec<Vec<f64>>,
    ints: Vec<Vec<i64>>,
}

impl Spare {
    /// Takes back the vectors of `arrays` that no one else holds any more.
    fn recycle(&mut self, arrays: Vec<Box<dyn Array>>) {
        for mut a in arrays {
            let any = a.as_any_mut();
            if let Some(p) = any.downcast_mut::<PrimitiveArray<f64>>() {
                let p = std::mem::replace(p, PrimitiveArray::new_empty(ArrowDataType::Float64));
                if let Some(m) = p.into_mut().right() {
                    self.floats.push(m.into_inner().1);
                }
            } else if let Some(p) = any.downcast_mut::<PrimitiveArray<i64>>() {
                let p = std::mem::replace(p, PrimitiveArray::new_empty(ArrowDataType::Int64));
                if let Some(m) = p.into_mut().right() {
                    self.ints.push(m.into_inner().1);
                }
            }
        }
    }

    /// Gives `v` a spare vector's memory if it has none.
    fn refill<T>(pool: &mut Vec<Vec<T>>, v: &mut Vec<T>) {
        if v.capacity() == 0
            && let Some(mut spare) = pool.pop()
        {
            spare.clear();
            *v = spare;
        }
    }
}

/// How each column is encoded in Parquet, in `SessionRow::COLUMNS` order.
const ENCODINGS: [Encoding; 19] = {
    use Encoding::{DeltaBinaryPacked as Delta, Plain, RleDictionary as Dict};
    [
        Dict, Delta, Plain, Plain, Dict, Plain, Dict, Plain, Plain, Plain, Plain, Plain, Plain,
        Plain, Plain, Plain, Plain, Plain, Dict,
    ]
};

/// Which columns carry min and max statistics, in `SessionRow::COLUMNS` order: the keys a
/// reader selects row groups by (run, sample, time, axis, direction, target, flags). The
/// measured floats carry their null count only: their min/max cost a tenth of a replay's
/// time and no errmap reader uses them.
const MIN_MAX: [bool; 19] = [
    true, true, true, true, true, false, true, false, false, false, false, false, false, false,
    false, false, false, false, true,
];

impl Columns {
    /// The rows of `rows`, as columns.
    pub(crate) fn from_rows(rows: &[SessionRow]) -> Self {
        let mut c = Columns::default();
        for r in rows {
            c.push(r);
        }
        c
    }

    /// Appends one row.
    pub(crate) fn push(&mut self, r: &SessionRow) {
        self.run.push(i64::from(r.run));
        self.sample.push(r.sample);
        self.t_s.push(r.t_s);
        self.axis.push(r.axis);
        self.direction.push(i64::from(r.direction));
        self.feed_mm_s.push(r.feed_mm_s);
        self.target.push(i64::from(r.target));
        self.x_mm.push(r.x_mm);
        self.y_mm.push(r.y_mm);
        self.z_mm.push(r.z_mm);
        self.scale_mm.push(r.scale_mm);
        self.laser_mm.push(r.laser_mm);
        self.error_um.push(r.error_um);
        self.air_temp_c.push(r.air_temp_c);
        self.air_pressure_hpa.push(r.air_pressure_hpa);
        self.air_rh_pct.push(r.air_rh_pct);
        self.scale_temp_c.push(r.scale_temp_c);
        self.part_temp_c.push(r.part_temp_c);
        self.flags.push(i64::from(r.flags));
    }

    /// Rows held.
    pub(crate) fn len(&self) -> usize {
        self.run.len()
    }

    /// Whether no row is held.
    pub(crate) fn is_empty(&self) -> bool {
        self.run.is_empty()
    }

    /// The columns as Arrow arrays in `SessionRow::COLUMNS` order. The vectors move into
    /// the arrays (no copy); [`Columns::recycle`] takes them back once the arrays are
    /// written. Leaves the batch empty.
    fn take_arrays(&mut self) -> Vec<Box<dyn Array>> {
        let int = |v: &mut Vec<i64>| PrimitiveArray::<i64>::from_vec(std::mem::take(v)).boxed();
        let run = int(&mut self.run);
        let sample = int(&mut self.sample);
        let direction = int(&mut self.direction);
        let target = int(&mut self.target);
        let flags = int(&mut self.flags);
        let float = |v: &mut Vec<f64>| PrimitiveArray::<f64>::from_vec(std::mem::take(v)).boxed();
        let t_s = float(&mut self.t_s);
        let scale_mm = float(&mut self.scale_mm);
        let laser_mm = float(&mut self.laser_mm);
        let error_um = float(&mut self.error_um);
        let optional = |o: &mut Optional| {
            let validity = o.validity();
            o.missing.clear();
            let values = std::mem::take(&mut o.values);
            PrimitiveArray::<f64>::new(ArrowDataType::Float64, values.into(), validity).boxed()
        };
        let feed_mm_s = optional(&mut self.feed_mm_s);
        let x_mm = optional(&mut self.x_mm);
        let y_mm = optional(&mut self.y_mm);
        let z_mm = optional(&mut self.z_mm);
        let air_temp_c = optional(&mut self.air_temp_c);
        let air_pressure_hpa = optional(&mut self.air_pressure_hpa);
        let air_rh_pct = optional(&mut self.air_rh_pct);
        let scale_temp_c = optional(&mut self.scale_temp_c);
        let part_temp_c = optional(&mut self.part_temp_c);
        let axis =
            MutableBinaryViewArray::<str>::from_values_iter(self.axis.iter().map(|a| a.as_str()))
                .freeze()
                .boxed();
        self.axis.clear();
        vec![
            run,
            sample,
            t_s,
            axis,
            direction,
            feed_mm_s,
            target,
            x_mm,
            y_mm,
            z_mm,
            scale_mm,
            laser_mm,
            error_um,
            air_temp_c,
            air_pressure_hpa,
            air_rh_pct,
            scale_temp_c,
            part_temp_c,
            flags,
        ]
    }

    /// Takes back the vectors of arrays from [`Columns::take_arrays`] once written, for
    /// the next batch.
    fn recycle(&mut self, arrays: Vec<Box<dyn Array>>) {
        let spare = &mut self.spare;
        spare.recycle(arrays);
        for v in [
            &mut self.run,
            &mut self.sample,
            &mut self.direction,
            &mut self.target,
            &mut self.flags,
        ] {
            Spare::refill(&mut spare.ints, v);
        }
        for v in [
            &mut self.t_s,
            &mut self.scale_mm,
            &mut self.laser_mm,
            &mut self.error_um,
            &mut self.feed_mm_s.values,
            &mut self.x_mm.values,
            &mut self.y_mm.values,
            &mut self.z_mm.values,
            &mut self.air_temp_c.values,
            &mut self.air_pressure_hpa.values,
            &mut self.air_rh_pct.values,
            &mut self.scale_temp_c.values,
            &mut self.part_temp_c.values,
        ] {
            Spare::refill(&mut spare.floats, v);
        }
    }

    /// The columns as a polars `DataFrame` with the spec's column names and order;
    /// leaves the batch empty.
    pub(crate) fn take_frame(&mut self) -> PolarsResult<DataFrame> {
        let n = self.len();
        let columns = SessionRow::COLUMNS
            .iter()
            .zip(self.take_arrays())
            .map(|(name, array)| {
                Series::from_arrow(PlSmallStr::from_static(name), array).map(Column::from)
            })
            .collect::<PolarsResult<Vec<_>>>()?;
        DataFrame::new(n, columns)
    }
}

/// A session table's Parquet file, written one row group per [`ParquetSink::write`] (see
/// the module docs).
pub(crate) struct ParquetSink<W: Write> {
    writer: FileWriter<W>,
    options: WriteOptions,
    zstd: Zstd,
}

/// The zstd level of the session table's pages.
const ZSTD_LEVEL: i32 = 1;

/// Compresses pages with one zstd context, reused from page to page and row group to row
/// group. The pages are the standard Parquet zstd pages polars' own `Compressor` makes
/// (the whole buffer of a V1 data page, or of a dictionary page, is one zstd frame).
struct Zstd(zstd::bulk::Compressor<'static>);

impl Zstd {
    fn new() -> std::io::Result<Self> {
        zstd::bulk::Compressor::new(ZSTD_LEVEL).map(Zstd)
    }

    fn frame(&mut self, input: &[u8]) -> PolarsResult<Vec<u8>> {
        let mut out = Vec::with_capacity(zstd::zstd_safe::compress_bound(input.len()));
        self.0
            .compress_to_buffer(input, &mut out)
            .map_err(|e| polars_err!(ComputeError: "zstd: {e}"))?;
        Ok(out)
    }

    fn page(&mut self, page: Page) -> PolarsResult<CompressedPage> {
        Ok(match page {
            Page::Data(page) => {
                if !matches!(page.header(), DataPageHeader::V1(_)) {
                    // Not written by this module (its pages are V1); kept correct anyway.
                    return Ok(polars_parquet::parquet::write::compress(
                        Page::Data(page),
                        Vec::new(),
                        CompressionOptions::Zstd(Some(ZstdLevel::try_new(ZSTD_LEVEL)?)),
                    )?);
                }
                let rows = page.num_rows().unwrap_or_else(|| page.num_values());
                let buffer = self.frame(page.buffer())?;
                CompressedPage::Data(CompressedDataPage::new(
                    page.header().clone(),
                    CowBuffer::Owned(buffer),
                    Compression::Zstd,
                    page.buffer().len(),
                    page.descriptor.clone(),
                    rows,
                ))
            }
            Page::Dict(page) => {
                let buffer = self.frame(&page.buffer)?;
                CompressedPage::Dict(CompressedDictPage::new(
                    CowBuffer::Owned(buffer),
                    Compression::Zstd,
                    page.buffer.len(),
                    page.num_values,
                    page.is_sorted,
                ))
            }
        })
    }
}

/// One column chunk's compressed pages, handed to the file writer one at a time.
struct Pages {
    pages: std::vec::IntoIter<CompressedPage>,
    current: Option<CompressedPage>,
}

impl FallibleStreamingIterator for Pages {
    type Item = CompressedPage;
    type Error = PolarsError;

    fn advance(&mut self) -> PolarsResult<()> {
        self.current = self.pages.next();
        Ok(())
    }

    fn get(&self) -> Option<&CompressedPage> {
        self.current.as_ref()
    }
}

impl<W: Write> std::fmt::Debug for ParquetSink<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParquetSink").finish_non_exhaustive()
    }
}

impl<W: Write> ParquetSink<W> {
    /// Starts the file: its magic bytes now, the schema with the footer.
    pub(crate) fn new(out: W) -> PolarsResult<Self> {
        let schema = Columns::default()
            .take_frame()?
            .schema()
            .to_arrow(CompatLevel::newest());
        let options = WriteOptions {
            statistics: StatisticsOptions::default(),
            version: Version::V1,
            compression: CompressionOptions::Zstd(Some(ZstdLevel::try_new(ZSTD_LEVEL)?)),
            data_page_size: None,
        };
        Ok(ParquetSink {
            writer: FileWriter::try_new(out, schema, options)?,
            options,
            zstd: Zstd::new().map_err(|e| polars_err!(ComputeError: "zstd: {e}"))?,
        })
    }

    /// Writes `columns` as one row group (nothing when it holds no row) and empties it.
    pub(crate) fn write(&mut self, columns: &mut Columns) -> PolarsResult<()> {
        if columns.is_empty() {
            return Ok(());
        }
        let rows = columns.len();
        let arrays = columns.take_arrays();
        let fields = self.writer.parquet_schema().fields().to_vec();
        let options = self.options;
        let mut pages = Vec::with_capacity(fields.len());
        for (((array, field), encoding), keyed) in
            arrays.iter().zip(fields).zip(ENCODINGS).zip(MIN_MAX)
        {
            let options = if keyed {
                options
            } else {
                WriteOptions {
                    statistics: StatisticsOptions {
                        min_value: false,
                        max_value: false,
                        ..options.statistics
                    },
                    ..options
                }
            };
            for encoded in array_to_columns(array, field, options, &[encoding])? {
                let compressed = encoded
                    .map(|page| self.zstd.page(page?))
                    .collect::<PolarsResult<Vec<_>>>()?;
                pages.push(Ok(DynStreamingIterator::new(Pages {
                    pages: compressed.into_iter(),
                    current: None,
                })));
            }
        }
        self.writer
            .write(rows as u64, DynIter::new(pages.into_iter()))?;
        columns.recycle(arrays);
        Ok(())
    }

    /// Writes the footer and hands the output back (to flush or sync it).
    pub(crate) fn finish(mut self) -> PolarsResult<W> {
        self.writer.end(None)?;
        Ok(self.writer.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::{SessionWriter, read_session};

    /// Rows whose optional columns are missing at the start (before the first MARK, ENV
    /// and MATERIAL frames), as a capture's first rows are, on axis Y.
    fn rows(n: usize) -> Vec<SessionRow> {
        (0..n)
            .map(|k| {
                let kf = k as f64;
                SessionRow {
                    run: (k / 4) as u32,
                    sample: 1000 + k as i64,
                    t_s: kf * 0.005,
                    axis: WireAxis::Y,
                    direction: if k % 8 < 4 { 1 } else { -1 },
                    feed_mm_s: (k >= 3).then_some(20.0),
                    target: if k % 3 == 0 { -1 } else { (k % 5) as i32 },
                    x_mm: Some(-12.5),
                    y_mm: Some(kf * 0.1 + 1e-7 * kf * kf),
                    z_mm: (k % 7 != 0).then_some(3.25),
                    scale_mm: kf * 0.1,
                    laser_mm: kf * 0.1 - 2e-6 * kf,
                    error_um: 2e-3 * kf,
                    air_temp_c: (k >= 5).then_some(20.0 + kf * 1e-3),
                    air_pressure_hpa: (k >= 5).then_some(1013.25),
                    air_rh_pct: (k >= 5).then_some(45.0),
                    scale_temp_c: (k >= 6).then_some(20.1),
                    part_temp_c: (k >= 9).then_some(19.9),
                    flags: (k % 11 == 0) as u8,
                }
            })
            .collect()
    }

    #[test]
    fn rows_with_missing_values_come_back_whole_through_many_row_groups() {
        let dir = tempfile::tempdir().expect("test");
        let path = dir.path().join("s.parquet");
        let rows = rows(23);
        // Row groups of 4: the missing values fall in some groups and not in others.
        let mut w = SessionWriter::with_batch(&path, 4).expect("test");
        for r in &rows {
            w.push(r.clone()).expect("test");
        }
        assert_eq!(w.finish().expect("test"), 23);
        assert_eq!(read_session(&path).expect("test"), rows);
    }

    #[test]
    fn the_next_batch_fills_the_memory_of_the_last() {
        let all = rows(600);
        let mut columns = Columns::from_rows(&all[..300]);
        let before = (
            columns.t_s.as_ptr(),
            columns.sample.as_ptr(),
            columns.x_mm.values.as_ptr(),
        );
        let mut sink = ParquetSink::new(Vec::new()).expect("test");
        sink.write(&mut columns).expect("test");
        assert!(columns.is_empty());
        // Every vector came back; the pool hands them out in some order, so compare sets.
        let floats: Vec<_> = [&columns.t_s, &columns.x_mm.values]
            .iter()
            .map(|v| v.capacity())
            .collect();
        assert!(floats.iter().all(|&c| c >= 300), "{floats:?}");
        assert!(columns.sample.capacity() >= 300);
        let mut float_ptrs: Vec<_> = [
            &columns.t_s,
            &columns.scale_mm,
            &columns.laser_mm,
            &columns.error_um,
            &columns.feed_mm_s.values,
            &columns.x_mm.values,
            &columns.y_mm.values,
            &columns.z_mm.values,
            &columns.air_temp_c.values,
            &columns.air_pressure_hpa.values,
            &columns.air_rh_pct.values,
            &columns.scale_temp_c.values,
            &columns.part_temp_c.values,
        ]
        .iter()
        .map(|v| v.as_ptr())
        .collect();
        float_ptrs.sort();
        assert!(float_ptrs.binary_search(&before.0).is_ok());
        assert!(float_ptrs.binary_search(&before.2).is_ok());
        let int_ptrs = [
            columns.run.as_ptr(),
            columns.sample.as_ptr(),
            columns.direction.as_ptr(),
            columns.target.as_ptr(),
            columns.flags.as_ptr(),
        ];
        assert!(int_ptrs.contains(&before.1));
        // And the file is still right when the reused vectors carry the next batch.
        for r in &all[300..] {
            columns.push(r);
        }
        sink.write(&mut columns).expect("test");
        let bytes = sink.finish().expect("test");
        let dir = tempfile::tempdir().expect("test");
        let path = dir.path().join("two.parquet");
        std::fs::write(&path, bytes).expect("test");
        let back = read_session(&path).expect("test");
        assert_eq!(back, all);
    }

    #[test]
    fn the_sample_counter_costs_a_few_bits_a_row_and_pages_are_zstd() {
        let rows = rows(60_000);
        let mut sink = ParquetSink::new(Vec::new()).expect("test");
        sink.write(&mut Columns::from_rows(&rows)).expect("test");
        let bytes = sink.finish().expect("test");
        let meta =
            polars_parquet::read::read_metadata(&mut std::io::Cursor::new(&bytes)).expect("test");
        let group = &meta.row_groups[0];
        let chunk = |name: &str| {
            group
                .parquet_columns()
                .iter()
                .find(|c| c.descriptor().path_in_schema[0].as_str() == name)
                .expect("test")
        };
        // Delta encoding of a counter: a few bytes per block of 128 values; plain 8-byte
        // integers would take ~100 kB even after zstd.
        let sample = chunk("sample").compressed_size();
        assert!(sample < 2_000, "sample column {sample} B");
        for c in group.parquet_columns() {
            assert_eq!(
                c.compression(),
                polars_parquet::parquet::compression::Compression::Zstd
            );
        }
    }
}
