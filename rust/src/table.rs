//! A fast reader for the numeric text tables trajectories come in (TUM, KITTI, CSV): the
//! regular case only. Lines split on `\n` (a `\r` before it is dropped); `#` starts a
//! comment to the end of the line; blank lines are skipped; fields are separated by runs of
//! spaces and tabs (or by one `sep` byte, blanks around it allowed); every data line must
//! have the first data line's number of fields, and every field must be a plain decimal
//! number (`[+-]digits[.digits][(e|E)[+-]digits]`). Anything else - a word, `nan`, a ragged
//! row, an empty field - makes [`read_table`] return `None`, and the caller reads the file
//! with its general parser, which says what is wrong and where. Numbers are parsed by Rust's
//! correctly rounded `f64` parser, as Python's `float` does; chunks of lines are parsed in
//! parallel and the rows keep their order.

use rayon::prelude::*;

/// The field separator: runs of blanks, or one byte with optional blanks around it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sep {
    Blanks,
    Byte(u8),
}

/// A table's numbers, row-major, and its number of columns.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub values: Vec<f64>,
    pub rows: usize,
    pub cols: usize,
}

fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

/// Exact powers of ten as `f64` (10^22 is the largest).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A plain decimal number (`[+-]digits[.digits][(e|E)[+-]digits]`, at least one digit
/// before the exponent), correctly rounded; `None` for any other text.
fn number(f: &[u8]) -> Option<f64> {
    match number_at(f, 0) {
        Some((v, end)) if end == f.len() => Some(v),
        _ => None,
    }
}

/// The bytes that end a field of a blank-separated line.
fn ends_field(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | b'#')
}

/// The plain decimal number starting at `t[i]` and where it ends (the first byte that
/// [`ends_field`], or a byte it cannot contain: the caller checks what follows). One pass:
/// Clinger's fast path when the significant digits fit in 2^53 and the power of ten is
/// exact (one correctly rounded multiplication or division: the usual case of trajectory
/// files), else Rust's parser on the same bytes.
#[inline(always)]
fn number_at(t: &[u8], start: usize) -> Option<(f64, usize)> {
    let n = t.len();
    let (neg, mut i) = sign(t, start);
    // every digit counts (leading zeros too: more than 19 goes to the slow path, which is
    // only slower), eight at a time where eight are in a row
    let mut mant: u64 = 0;
    let mut digits = 0usize;
    let i0 = i;
    i = digit_run(t, i, &mut mant);
    digits += i - i0;
    let mut scale: i32 = 0; // digits after the point
    if i < n && t[i] == b'.' {
        let f0 = i + 1;
        i = digit_run(t, f0, &mut mant);
        scale = (i - f0) as i32;
        digits += i - f0;
    }
    if digits == 0 {
        return None;
    }
    let mut exp: i32 = 0;
    if i < n && (t[i] | 0x20) == b'e' {
        let (eneg, after) = sign(t, i + 1);
        i = after;
        let e0 = i;
        while i < n && t[i].is_ascii_digit() {
            exp = (exp * 10 + i32::from(t[i] - b'0')).min(100_000);
            i += 1;
        }
        if i == e0 {
            return None;
        }
        if eneg {
            exp = -exp;
        }
    }
    let e = exp - scale;
    if digits > 19 || mant >= 1 << 53 || !(-22..=22).contains(&e) {
        return Some((slow(&t[start..i])?, i));
    }
    let m = mant as f64;
    let v = if e < 0 {
        m / POW10[(-e) as usize]
    } else {
        m * POW10[e as usize]
    };
    Some((if neg { -v } else { v }, i))
}

/// An optional sign at `t[i]`: whether it is `-`, and where the digits start.
fn sign(t: &[u8], i: usize) -> (bool, usize) {
    match t.get(i) {
        Some(b'-') => (true, i + 1),
        Some(b'+') => (false, i + 1),
        _ => (false, i),
    }
}

/// Appends the run of ASCII digits starting at `t[i]` to `mant` (wrapping: the caller
/// counts the digits and takes the slow path past 19) and returns where the run ends.
/// Eight digits at a time (SWAR: one 64-bit load, a check, three multiplications).
#[inline(always)]
fn digit_run(t: &[u8], mut i: usize, mant: &mut u64) -> usize {
    while let Some(eight) = t.get(i..i + 8) {
        let mut x = u64::from_le_bytes(eight.try_into().unwrap_or([0; 8]));
        // all eight bytes in b'0'..=b'9'
        let all_digits = ((x & 0xF0F0_F0F0_F0F0_F0F0)
            | ((x.wrapping_add(0x0606_0606_0606_0606) & 0xF0F0_F0F0_F0F0_F0F0) >> 4))
            == 0x3333_3333_3333_3333;
        if !all_digits {
            break;
        }
        x = x.wrapping_sub(0x3030_3030_3030_3030);
        x = x.wrapping_mul(10).wrapping_add(x >> 8);
        let v = ((x & 0x0000_00FF_0000_00FF)
            .wrapping_mul(100 + (1_000_000 << 32))
            .wrapping_add(((x >> 16) & 0x0000_00FF_0000_00FF).wrapping_mul(1 + (10_000 << 32))))
            >> 32;
        *mant = mant.wrapping_mul(100_000_000).wrapping_add(v);
        i += 8;
    }
    while let Some(&b) = t.get(i) {
        if !b.is_ascii_digit() {
            break;
        }
        *mant = mant.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
        i += 1;
    }
    i
}

/// Counts a line of `fields` numbers (none: a blank or comment line) as a row; `None` when
/// it is not as long as the rows before it.
fn add_row(fields: usize, rows: &mut usize, cols: &mut usize) -> Option<()> {
    if fields > 0 {
        if *rows > 0 && fields != *cols {
            return None;
        }
        *cols = fields;
        *rows += 1;
    }
    Some(())
}

/// The data rows of a chunk of whole lines separated by blanks, in one pass over its bytes:
/// `(rows, columns)`, or `None` when it is not regular.
fn parse_blanks(t: &[u8], out: &mut Vec<f64>) -> Option<(usize, usize)> {
    let n = t.len();
    let (mut rows, mut cols) = (0usize, 0usize);
    let mut i = 0;
    while i < n {
        let mut fields = 0usize;
        // one line: fields, blanks, up to its end or a comment
        while i < n {
            let b = t[i];
            if b == b' ' || b == b'\t' {
                i += 1;
            } else if b == b'\n' {
                break;
            } else if b == b'#' {
                i += t[i..].iter().position(|&c| c == b'\n').unwrap_or(n - i);
                break;
            } else if b == b'\r' {
                // a CRLF line end; any other CR (old Mac line ends) is irregular
                if i + 1 < n && t[i + 1] != b'\n' {
                    return None;
                }
                i += 1;
            } else {
                let (v, end) = number_at(t, i)?;
                if end < n && !ends_field(t[end]) {
                    return None;
                }
                out.push(v);
                fields += 1;
                i = end;
            }
        }
        i += 1; // the line end
        add_row(fields, &mut rows, &mut cols)?;
    }
    Some((rows, cols))
}

fn slow(f: &[u8]) -> Option<f64> {
    std::str::from_utf8(f).ok()?.parse::<f64>().ok()
}

/// The fields of one line separated by `sep` (comment removed), appended to `out`; their
/// count, or `None` when one is not a plain number or is empty.
fn parse_line(line: &[u8], sep: u8, out: &mut Vec<f64>) -> Option<usize> {
    // a CRLF line end; any other CR (old Mac line ends) makes a field fail
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let line = match line.iter().position(|&b| b == b'#') {
        Some(k) => &line[..k],
        None => line,
    };
    if line.iter().all(|&b| is_blank(b)) {
        return Some(0);
    }
    let mut n = 0;
    for f in line.split(|&b| b == sep) {
        let a = f.iter().position(|&b| !is_blank(b))?;
        let z = f.len() - f.iter().rev().position(|&b| !is_blank(b)).unwrap_or(0);
        out.push(number(&f[a..z])?);
        n += 1;
    }
    Some(n)
}

/// `text` split into about `parts` chunks at line ends (at least 64 KiB each).
fn chunks(text: &[u8], parts: usize) -> Vec<&[u8]> {
    let target = text.len().div_ceil(parts.max(1)).max(1 << 16);
    let mut out = Vec::new();
    let mut start = 0;
    while start < text.len() {
        let mut end = (start + target).min(text.len());
        while end < text.len() && text[end - 1] != b'\n' {
            end += 1;
        }
        out.push(&text[start..end]);
        start = end;
    }
    out
}

/// Rows gathered block by block: the skipped lines still to skip, the numbers so far.
struct Rows {
    skip: usize,
    sep: Sep,
    values: Vec<f64>,
    rows: usize,
    cols: usize,
}

impl Rows {
    fn new(sep: Sep, skip: usize) -> Self {
        Rows {
            skip,
            sep,
            values: Vec::new(),
            rows: 0,
            cols: 0,
        }
    }

    /// Parse `text`, whole lines only (the last may lack its `\n`), in parallel chunks;
    /// `None` when the table is not regular.
    fn feed(&mut self, mut text: &[u8]) -> Option<()> {
        while self.skip > 0 && !text.is_empty() {
            text = match text.iter().position(|&b| b == b'\n') {
                Some(k) => &text[k + 1..],
                None => &[],
            };
            self.skip -= 1;
        }
        let sep = self.sep;
        let parts: Vec<Option<(Vec<f64>, usize, usize)>> =
            chunks(text, 4 * rayon::current_num_threads())
                .into_par_iter()
                .map(|chunk| {
                    let mut values = Vec::with_capacity(chunk.len() / 8);
                    if sep == Sep::Blanks {
                        let (rows, cols) = parse_blanks(chunk, &mut values)?;
                        return Some((values, rows, cols));
                    }
                    let (mut rows, mut cols) = (0usize, 0usize);
                    let Sep::Byte(byte) = sep else { return None };
                    for line in chunk.split(|&b| b == b'\n') {
                        add_row(parse_line(line, byte, &mut values)?, &mut rows, &mut cols)?;
                    }
                    Some((values, rows, cols))
                })
                .collect();
        for p in parts {
            let (v, r, c) = p?;
            if r == 0 {
                continue;
            }
            if self.cols != 0 && c != self.cols {
                return None;
            }
            self.cols = c;
            self.rows += r;
            self.values.extend_from_slice(&v);
        }
        Some(())
    }

    fn done(self) -> Table {
        Table {
            values: self.values,
            rows: self.rows,
            cols: self.cols,
        }
    }
}

/// Every data row of `text` after its first `skip` lines, or `None` when the table is not
/// regular (see the module documentation). A table without data rows has 0 rows, 0 columns.
pub fn read_table(text: &[u8], sep: Sep, skip: usize) -> Option<Table> {
    let mut rows = Rows::new(sep, skip);
    rows.feed(text)?;
    Some(rows.done())
}

/// Bytes of a file read and parsed at a time by [`read_table_file`] and [`read_tum_file`].
const BLOCK: usize = 8 << 20;

/// Appends up to [`BLOCK`] bytes of `file` to `buf` (without zero-filling them first);
/// the number of bytes read (0: the end of the file).
fn read_block(file: &mut std::fs::File, buf: &mut Vec<u8>) -> std::io::Result<usize> {
    use std::io::Read;
    file.take(BLOCK as u64).read_to_end(buf)
}

/// Where the whole lines of `buf` end: after its last `\n`, or its end once the file is
/// read (`got == 0`); 0 when no line is whole yet.
fn lines_end(buf: &[u8], got: usize) -> usize {
    if got == 0 {
        buf.len()
    } else {
        buf.iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1)
    }
}

/// Calls `feed(text, size, first)` on a file's text, whole lines at a time, in blocks of
/// about 8 MiB, so that the whole text is never held (`size`: the file's size; `first`:
/// the first call). The next block is read while `feed` parses the one before (two
/// buffers). Stops at the first `None` and returns `Ok(None)`.
fn for_each_block(
    path: &std::path::Path,
    mut feed: impl FnMut(&[u8], usize, bool) -> Option<()> + Send,
) -> std::io::Result<Option<()>> {
    let mut file = std::fs::File::open(path)?;
    let size = file.metadata().map(|m| m.len() as usize).unwrap_or(0);
    let cap = BLOCK.min(size.max(1)) + (1 << 16);
    let (mut cur, mut next) = (Vec::with_capacity(cap), Vec::with_capacity(cap));
    let mut got = read_block(&mut file, &mut cur)?;
    let mut first = true;
    loop {
        let mut end = lines_end(&cur, got);
        while end == 0 && got > 0 {
            // a line longer than the block: read on
            got = read_block(&mut file, &mut cur)?;
            end = lines_end(&cur, got);
        }
        let last = got == 0;
        let (text, rest) = cur.split_at(end);
        let file = &mut file;
        let next_buf = &mut next;
        let feed = &mut feed;
        let (read, fed) = rayon::join(
            move || {
                next_buf.clear();
                next_buf.extend_from_slice(rest);
                if last {
                    Ok(0)
                } else {
                    read_block(file, next_buf)
                }
            },
            move || text.is_empty() || feed(text, size, first).is_some(),
        );
        if !fed {
            return Ok(None);
        }
        got = read?;
        first &= text.is_empty();
        if last {
            return Ok(Some(()));
        }
        std::mem::swap(&mut cur, &mut next);
    }
}

/// [`read_table`] of a file, read in blocks of 8 MiB so that the whole text is never held:
/// the memory is the numbers (8 bytes each) and one block. The numbers' buffer is sized
/// once from the first block's numbers per byte. `Ok(None)`: not a regular table.
pub fn read_table_file(
    path: &std::path::Path,
    sep: Sep,
    skip: usize,
) -> std::io::Result<Option<Table>> {
    let mut rows = Rows::new(sep, skip);
    let done = for_each_block(path, |text, size, first| {
        rows.feed(text)?;
        if first {
            // numbers per byte of this block, times the file's size, and some slack
            let per_byte = rows.values.len() as f64 / text.len() as f64;
            let want = (per_byte * size as f64 * 1.02) as usize + 1024;
            rows.values.reserve(want.saturating_sub(rows.values.len()));
        }
        Some(())
    })?;
    Ok(done.map(|()| rows.done()))
}

/// The poses of a TUM file (`t x y z qx qy qz qw` a line) in the layout
/// `slamq.Trajectory` keeps: timestamps, positions `(n, 3)` and unit quaternions `(n, 4)`
/// in w, x, y, z order, row-major.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Poses {
    pub t: Vec<f64>,
    pub p: Vec<f64>,
    pub q: Vec<f64>,
}

impl Poses {
    /// The number of poses.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there is no pose.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

/// The squared norm of a quaternion `(w, x, y, z)` summed in that order, as numpy's
/// `einsum("ij,ij->i", q, q)` sums the rows of the column-major array the general TUM
/// reader hands `slamq.Trajectory` (`arr[:, [7, 4, 5, 6]]`), so that the unit quaternions
/// are bit-equal to those of that path.
pub fn quat_norm2(w: f64, x: f64, y: f64, z: f64) -> f64 {
    w * w + x * x + y * y + z * z
}

/// One chunk's rows (8 numbers each, row-major) written into its slices of the columns;
/// `(clean, first timestamp, last timestamp)`. Clean: every number finite, every timestamp
/// at least the one before it, every quaternion's norm at least 1e-12 (what
/// `slamq.Trajectory` checks).
fn tum_rows(v: &[f64], t: &mut [f64], p: &mut [f64], q: &mut [f64]) -> (bool, f64, f64) {
    let mut clean = true;
    let mut prev = f64::NEG_INFINITY;
    for (i, r) in v.chunks_exact(8).enumerate() {
        clean &= r.iter().all(|x| x.is_finite());
        clean &= r[0] >= prev;
        prev = r[0];
        t[i] = r[0];
        p[3 * i..3 * i + 3].copy_from_slice(&r[1..4]);
        let (w, x, y, z) = (r[7], r[4], r[5], r[6]);
        let norm = quat_norm2(w, x, y, z).sqrt();
        clean &= norm >= 1e-12;
        q[4 * i] = w / norm;
        q[4 * i + 1] = x / norm;
        q[4 * i + 2] = y / norm;
        q[4 * i + 3] = z / norm;
    }
    let first = v.first().copied().unwrap_or(f64::NEG_INFINITY);
    (clean, first, prev)
}

/// The poses of a regular TUM file (blank-separated, 8 plain decimal numbers a data line,
/// `#` comments) read in blocks and parsed in parallel straight into [`Poses`] (no table
/// of all the numbers is held). `Ok(None)` unless the file is a regular table of 8 columns
/// with at least one row whose poses `slamq.Trajectory` accepts as they are (finite numbers,
/// non-decreasing timestamps, non-zero quaternions): the caller's general reader then
/// reads it, and says what is wrong.
pub fn read_tum_file(path: &std::path::Path) -> std::io::Result<Option<Poses>> {
    let mut out = Poses::default();
    let mut last_t = f64::NEG_INFINITY;
    // each chunk's numbers, the buffers kept from block to block
    let mut parts: Vec<Vec<f64>> = Vec::new();
    let done = for_each_block(path, |text, size, first| {
        let chunks = chunks(text, 4 * rayon::current_num_threads());
        parts.resize_with(chunks.len(), Vec::new);
        let parts = &mut parts[..chunks.len()];
        let regular = chunks
            .into_par_iter()
            .zip(parts.par_iter_mut())
            .all(|(chunk, values)| {
                values.clear();
                values.reserve(chunk.len() / 8);
                matches!(parse_blanks(chunk, values), Some((rows, cols)) if rows == 0 || cols == 8)
            });
        if !regular {
            return None;
        }
        let rows: usize = parts.iter().map(|v| v.len() / 8).sum();
        if first {
            let want = (rows as f64 / text.len() as f64 * size as f64 * 1.02) as usize + 128;
            out.t.reserve(want);
            out.p.reserve(3 * want);
            out.q.reserve(4 * want);
        }
        let n0 = out.len();
        out.t.resize(n0 + rows, 0.0);
        out.p.resize(3 * (n0 + rows), 0.0);
        out.q.resize(4 * (n0 + rows), 0.0);
        let (mut t, mut p, mut q) = (&mut out.t[n0..], &mut out.p[3 * n0..], &mut out.q[4 * n0..]);
        let mut jobs = Vec::with_capacity(parts.len());
        for v in parts.iter() {
            let r = v.len() / 8;
            let (t1, t2) = std::mem::take(&mut t).split_at_mut(r);
            let (p1, p2) = std::mem::take(&mut p).split_at_mut(3 * r);
            let (q1, q2) = std::mem::take(&mut q).split_at_mut(4 * r);
            (t, p, q) = (t2, p2, q2);
            jobs.push((v.as_slice(), t1, p1, q1));
        }
        let checks: Vec<(bool, f64, f64)> = jobs
            .into_par_iter()
            .map(|(v, t, p, q)| tum_rows(v, t, p, q))
            .collect();
        for ((clean, first_t, end_t), v) in checks.into_iter().zip(parts.iter()) {
            if !clean || (!v.is_empty() && first_t < last_t) {
                return None;
            }
            if !v.is_empty() {
                last_t = end_t;
            }
        }
        Some(())
    })?;
    Ok(done.and_then(|()| (!out.is_empty()).then_some(out)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_tum_table_with_comments_blanks_and_crlf() {
        let t = b"# t x y\n1.5 2 -3e2\r\n\n  4\t5.25   6 # end\n";
        let got = read_table(t, Sep::Blanks, 0).unwrap();
        assert_eq!((got.rows, got.cols), (2, 3));
        assert_eq!(got.values, vec![1.5, 2.0, -300.0, 4.0, 5.25, 6.0]);
    }

    #[test]
    fn irregular_tables_are_left_to_the_general_parser() {
        for bad in [
            &b"1 2 3\n4 5\n"[..],
            b"1 2 3\n4 5 6 7\n",
            b"1 2 nan\n",
            b"1 2 inf\n",
            b"1 x 3\n",
            b"1 2 3e\n",
            b"1 . 3\n",
            b"0x10 1\n",
            b"1_000 2\n",
            b"1 2 3\r4 5 6\r",
        ] {
            assert_eq!(read_table(bad, Sep::Blanks, 0), None, "{:?}", bad);
        }
        assert_eq!(read_table(b"1,,3\n", Sep::Byte(b','), 0), None);
    }

    #[test]
    fn csv_with_blanks_and_a_header_skipped() {
        let t = b"time,x,y\n1, 2 ,3\n4,5,6\n";
        let got = read_table(t, Sep::Byte(b','), 1).unwrap();
        assert_eq!((got.rows, got.cols), (2, 3));
        assert_eq!(got.values, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn parsing_is_correctly_rounded_and_chunking_keeps_the_order() {
        let mut text = String::new();
        for i in 0..100_000 {
            text.push_str(&format!("{}.{:03} 0.1 {}e-7\n", i, i % 1000, i));
        }
        let got = read_table(text.as_bytes(), Sep::Blanks, 0).unwrap();
        assert_eq!((got.rows, got.cols), (100_000, 3));
        for i in [0usize, 1, 65_535, 99_999] {
            let want: f64 = format!("{}.{:03}", i, i % 1000).parse().unwrap();
            assert_eq!(got.values[3 * i], want);
            assert_eq!(got.values[3 * i + 1], 0.1);
        }
    }

    #[test]
    fn the_fast_path_equals_rusts_parser() {
        let cases = [
            "0",
            "-0",
            "+0.0",
            "1",
            "-1.5",
            "1600000000.123456",
            "0.123456789",
            "1e22",
            "1e23",
            "9007199254740993",
            "123456789012345678901",
            "4.9e-324",
            "1.7976931348623157e308",
            "0.1",
            "0.30000000000000004",
            "-2.5E-3",
            "00012.3400",
            "5e-22",
            "3.14159265358979323",
            ".5",
            "5.",
            "7e0",
            "1e-400",
            "2e400",
        ];
        for c in cases {
            let want: f64 = c.parse().unwrap();
            let got = number(c.as_bytes()).unwrap();
            assert_eq!(got.to_bits(), want.to_bits(), "{c}");
        }
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let s = format!(
                "{}.{:0w$}",
                x % 10_000_000_000,
                x % 1_000_000_000,
                w = (x % 12) as usize
            );
            let want: f64 = s.parse().unwrap();
            assert_eq!(
                number(s.as_bytes()).unwrap().to_bits(),
                want.to_bits(),
                "{s}"
            );
        }
    }

    #[test]
    fn digit_runs_equal_a_byte_by_byte_count() {
        let alphabet = b"0123456789/:. -+eE\n\xff\xfa\x00\xb0\xb9";
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        for _ in 0..100_000 {
            let mut t = Vec::new();
            for _ in 0..(x % 24) {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let pick = if x % 3 == 0 {
                    x as usize
                } else {
                    (x % 10) as usize
                };
                t.push(alphabet[pick % alphabet.len()]);
            }
            for start in 0..t.len().min(4) {
                let (mut got, mut want) = (7u64, 7u64);
                let end = digit_run(&t, start, &mut got);
                let mut i = start;
                while i < t.len() && t[i].is_ascii_digit() {
                    want = want.wrapping_mul(10).wrapping_add(u64::from(t[i] - b'0'));
                    i += 1;
                }
                assert_eq!((end, got), (i, want), "{t:?} from {start}");
            }
        }
    }

    #[test]
    fn a_file_read_in_blocks_equals_the_text_read_at_once() {
        let dir = std::env::temp_dir().join(format!("slamq_table_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.txt");
        let mut text = String::from("# header\nskipped line\n");
        for i in 0..400_000 {
            text.push_str(&format!("{i} {}.25 -{}e-3\n", i % 977, i % 13));
        }
        std::fs::write(&p, &text).unwrap(); // about 9 MiB: more than one block
        let whole = read_table(text.as_bytes(), Sep::Blanks, 2).unwrap();
        let blocks = read_table_file(&p, Sep::Blanks, 2).unwrap().unwrap();
        assert_eq!(whole, blocks);
        assert_eq!((blocks.rows, blocks.cols), (400_000, 3));
        std::fs::write(&p, "1 2\n3\n").unwrap();
        assert_eq!(read_table_file(&p, Sep::Blanks, 0).unwrap(), None);
        std::fs::write(&p, "1 2").unwrap(); // no final line end
        assert_eq!(
            read_table_file(&p, Sep::Blanks, 0).unwrap().unwrap().values,
            vec![1.0, 2.0]
        );
        assert!(read_table_file(&dir.join("absent"), Sep::Blanks, 0).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_tum_file_read_into_columns_equals_its_table() {
        let dir = std::env::temp_dir().join(format!("slamq_tum_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.txt");
        let mut text = String::from("# t x y z qx qy qz qw\n");
        for i in 0..250_000 {
            // about 17 MiB: three blocks; a comment and a blank line now and then
            text.push_str(&format!(
                "{}.{:06} {}.5 -{} 0.{:09} 0.25 -0.{:03} {}.75 1.{}\n",
                1_600_000_000 + i / 100,
                (i % 100) * 10_000,
                i % 977,
                i % 13,
                i * 7919 % 1_000_000_000,
                i % 1000,
                i % 3,
                i % 10
            ));
            if i % 50_000 == 7 {
                text.push_str("# a comment\n\n");
            }
        }
        std::fs::write(&p, &text).unwrap();
        let table = read_table(text.as_bytes(), Sep::Blanks, 0).unwrap();
        let poses = read_tum_file(&p).unwrap().unwrap();
        assert_eq!(poses.len(), 250_000);
        for (i, r) in table.values.chunks_exact(8).enumerate() {
            assert_eq!(poses.t[i], r[0]);
            assert_eq!(&poses.p[3 * i..3 * i + 3], &r[1..4]);
            let n = quat_norm2(r[7], r[4], r[5], r[6]).sqrt();
            let want = [r[7] / n, r[4] / n, r[5] / n, r[6] / n];
            assert_eq!(&poses.q[4 * i..4 * i + 4], &want);
        }
        // a timestamp going back, a zero quaternion, 7 columns, no rows: not taken here
        let back = text.replacen("1600001000.000000", "1500000000.000000", 1);
        let zero = format!("{text}1700000000 0 0 0 0 0 0 0\n");
        for bad in [back, zero, "0 1 2 3 4 5 6\n".into(), "# none\n".into()] {
            std::fs::write(&p, &bad).unwrap();
            assert_eq!(read_tum_file(&p).unwrap(), None);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn empty_and_comment_only_tables_have_no_rows() {
        let got = read_table(b"# only\n\n", Sep::Blanks, 0).unwrap();
        assert_eq!((got.rows, got.cols), (0, 0));
        assert_eq!(read_table(b"", Sep::Blanks, 5).unwrap().rows, 0);
    }
}
#[cfg(test)]
mod timing {
    #[test]
    #[ignore]
    fn time_read() {
        let p = std::env::var("TABLE").unwrap();
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let t1 = 0.0;
            let got = super::read_table_file(std::path::Path::new(&p), super::Sep::Blanks, 0)
                .unwrap()
                .unwrap();
            let t2 = t.elapsed().as_secs_f64();
            eprintln!(
                "read {:.3} parse {:.3} rows {} threads {}",
                t1,
                t2 - t1,
                got.rows,
                rayon::current_num_threads()
            );
        }
    }
}
