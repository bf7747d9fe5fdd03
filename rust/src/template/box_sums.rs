//! Sums over every h × w window of an array (the normalisation of the correlation), one output
//! row at a time: column sums of h rows, as running sums updated row by row and started afresh
//! at the first row of every task (so the rounding carried along stays that of nearby rows: a
//! bright pixel far away cannot leave its rounding in the variance of a flat window); then
//! sums of w consecutive column sums by doubling (sums of 1, 2, 4, … columns, combined along
//! the binary digits of w): ⌈log₂ w⌉ + popcount(w) vector passes over the row, no serial
//! chain of additions and no rounding carried from one window to the next.

use crate::image::Scratch;

/// Window sums [Σ a, Σ a²] of consecutive output rows, from a given first row on.
pub(crate) struct RowWindows<'a> {
    a: &'a [f64],
    cols: usize,
    h: usize,
    w: usize,
    /// The next output row.
    y: usize,
    /// Σ over the h rows from `y` of a and of a², per column.
    columns: [Scratch; 2],
    spare: Scratch,
}

impl<'a> RowWindows<'a> {
    /// The sums of the h × w windows of the rows × cols array `a`, from output row `y` on.
    #[inline(always)]
    pub(crate) fn new(a: &'a [f64], cols: usize, (h, w): (usize, usize), y: usize) -> Self {
        let mut columns = [Scratch::zeros(cols), Scratch::zeros(cols)];
        for i in 0..h {
            let line = &a[(y + i) * cols..(y + i + 1) * cols];
            let [c1, c2] = &mut columns;
            for ((s, q), &x) in c1.iter_mut().zip(c2.iter_mut()).zip(line) {
                *s += x;
                *q += x * x;
            }
        }
        Self {
            a,
            cols,
            h,
            w,
            y,
            columns,
            spare: Scratch::to_overwrite(2 * cols),
        }
    }

    /// Fills the sums [Σ a, Σ a²] of the next output row (cols − w + 1 entries each).
    #[inline(always)]
    pub(crate) fn next_row(&mut self, sums: &mut [f64], squares: &mut [f64]) {
        let [c1, c2] = &mut self.columns;
        row_sums(c1, self.w, &mut self.spare, sums);
        row_sums(c2, self.w, &mut self.spare, squares);
        let (cols, y) = (self.cols, self.y);
        let entering = y + self.h;
        if entering * cols < self.a.len() {
            let old = &self.a[y * cols..(y + 1) * cols];
            let new = &self.a[entering * cols..(entering + 1) * cols];
            for ((s, q), (&o, &n)) in c1.iter_mut().zip(c2.iter_mut()).zip(old.iter().zip(new)) {
                *s += n - o;
                *q += n * n - o * o;
            }
        }
        self.y += 1;
    }
}

/// out[x] = Σ_{j<w} columns[x + j] by doubling; `spare` is scratch of twice the columns'
/// length.
#[inline(always)]
fn row_sums(columns: &[f64], w: usize, spare: &mut [f64], out: &mut [f64]) {
    let cols = columns.len();
    let (mut power, mut next) = spare.split_at_mut(cols);
    // power[x] = Σ_{j<k} columns[x + j], valid for x ≤ cols − k
    power.copy_from_slice(columns);
    let (mut k, mut offset) = (1, None);
    loop {
        if w & k != 0 {
            let shift = offset.unwrap_or(0);
            let terms = out.iter_mut().zip(&power[shift..]);
            if offset.is_some() {
                terms.for_each(|(o, &p)| *o += p);
            } else {
                terms.for_each(|(o, &p)| *o = p);
            }
            offset = Some(shift + k);
        }
        if 2 * k > w {
            break;
        }
        let n = cols + 1 - 2 * k;
        let pairs = power[..n].iter().zip(&power[k..k + n]);
        next[..n]
            .iter_mut()
            .zip(pairs)
            .for_each(|(o, (&a, &b))| *o = a + b);
        std::mem::swap(&mut power, &mut next);
        k *= 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_equal_brute_force() {
        let (rows, cols) = (40, 70);
        let a: Vec<f64> = (0..rows * cols)
            .map(|k| ((k * 13 % 17) as f64) - 8.0)
            .collect();
        for (h, w, first) in [(5, 3, 0), (1, 1, 7), (8, 31, 2), (40, 70, 0)] {
            let (oh, ow) = (rows - h + 1, cols - w + 1);
            let mut windows = RowWindows::new(&a, cols, (h, w), first);
            let (mut s1, mut s2) = (vec![0.0; ow], vec![0.0; ow]);
            for y in first..oh {
                windows.next_row(&mut s1, &mut s2);
                for x in 0..ow {
                    let mut e = [0.0, 0.0];
                    for i in 0..h {
                        for j in 0..w {
                            let v = a[(y + i) * cols + x + j];
                            e[0] += v;
                            e[1] += v * v;
                        }
                    }
                    // integers: exact
                    assert_eq!([s1[x], s2[x]], e, "{h}x{w} at {x},{y}");
                }
            }
        }
    }
}
