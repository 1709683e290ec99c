//! The image filters of trackpy's pre-processing, on `f32` rows: a Gaussian low-pass
//! (zero outside the image, as `scipy.ndimage.correlate1d(mode='constant')`), a boxcar
//! running mean (edge pixels repeated, as `uniform_filter1d(mode='nearest')`, truncated
//! to whole grey levels as scipy does on an integer image), the
//! band-pass that subtracts one from the other, and a grey dilation (running maximum)
//! for the local maxima.

thread_local! {
    /// Image-sized buffers kept on each thread between frames: a fresh 3 MB buffer per
    /// filter pass cost more in the kernel's page zeroing than the filters themselves.
    static POOL: std::cell::RefCell<Vec<Vec<f32>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A zeroed buffer of `len`, from this thread's pool when it has one.
pub fn take(len: usize) -> Vec<f32> {
    let mut v = POOL.with(|p| p.borrow_mut().pop()).unwrap_or_default();
    v.clear();
    v.resize(len, 0.0);
    v
}

/// Returns a buffer to this thread's pool (a few are kept).
pub fn give(v: Vec<f32>) {
    POOL.with(|p| {
        let mut p = p.borrow_mut();
        if p.len() < 8 {
            p.push(v);
        }
    });
}

/// trackpy's `gaussian_kernel(sigma, truncate)`: taps `exp(-x²/2σ²)` for
/// |x| ≤ ⌊truncate·σ + ½⌋, normalised to sum 1.
pub fn gaussian_kernel(sigma: f64, truncate: f64) -> Vec<f32> {
    let lw = (truncate * sigma + 0.5) as i64;
    let taps: Vec<f64> = (-lw..=lw)
        .map(|x| (-(x * x) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = taps.iter().sum();
    taps.iter().map(|t| (t / sum) as f32).collect()
}

/// Correlates one row with `kernel` (odd length), zero beyond the row's ends, into
/// `out`: one tap at a time over the row, so the inner loop is a vectorised
/// multiply-add along memory.
fn correlate_row(row: &[f32], out: &mut [f32], kernel: &[f32]) {
    let w = row.len();
    let r = kernel.len() / 2;
    out.fill(0.0);
    for (t, &k) in kernel.iter().enumerate() {
        // out[x] += k · row[x + t − r] for the x where that index is inside.
        if t >= r {
            let d = t - r;
            if d >= w {
                continue;
            }
            for (o, v) in out[..w - d].iter_mut().zip(&row[d..]) {
                *o += k * v;
            }
        } else {
            let d = r - t;
            if d >= w {
                continue;
            }
            for (o, v) in out[d..].iter_mut().zip(&row[..w - d]) {
                *o += k * v;
            }
        }
    }
}

/// Row `y` of the correlation of every column with `kernel`, zero beyond the top and
/// bottom, into `out`; whole rows at a time so the inner loop runs along memory.
fn correlate_col_row(src: &[f32], w: usize, y: usize, out: &mut [f32], kernel: &[f32]) {
    let h = src.len() / w;
    let r = kernel.len() / 2;
    out.fill(0.0);
    let lo = y.saturating_sub(r);
    let hi = (y + r).min(h - 1);
    for yy in lo..=hi {
        let k = kernel[yy + r - y];
        let row = &src[yy * w..(yy + 1) * w];
        for (o, v) in out.iter_mut().zip(row) {
            *o += k * v;
        }
    }
}

/// Gaussian low-pass of σ = `sigma` px (trackpy's `lowpass`, `truncate` 4).
pub fn lowpass(img: &[f32], w: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 {
        return img.to_vec();
    }
    // Columns then rows, as scipy's axis 0 then axis 1, a row at a time: the column
    // pass of row y is finished before its row pass, so one row of scratch serves.
    let k = gaussian_kernel(sigma, 4.0);
    let mut out = take(img.len());
    let mut tmp = vec![0.0f32; w];
    for (y, o) in out.chunks_exact_mut(w).enumerate() {
        correlate_col_row(img, w, y, &mut tmp, &k);
        correlate_row(&tmp, o, &k);
    }
    out
}

/// trackpy's `boxcar` on an integer image, which scipy's `uniform_filter1d` writes back
/// into the image's integer type: the running mean along columns, truncated, then
/// along rows, truncated (the values are whole numbers, so the sums are exact).
#[inline(never)]
pub fn boxcar_truncated(img: &[f32], w: usize, size: usize) -> Vec<f32> {
    if size <= 1 {
        return img.to_vec();
    }
    let h = img.len() / w;
    let r = (size / 2) as i64;
    let n = size as f64;
    let inv = 1.0 / n;
    // ⌊a/n⌋ for a whole a ≥ 0 by a multiply: a·(1/n) is within an ulp of a/n, which
    // only matters when a/n is whole and the product falls just below; the `+1` test
    // puts that back. (A division per pixel cost more than the rest of the boxcar.)
    let div = |a: f64| {
        let q = (a * inv) as i32;
        q + i32::from(f64::from(q + 1) * n <= a)
    };
    // Sums of whole numbers below 2^53 are exact in f64, and so is the truncated
    // quotient: a non-integer a/n lies at least 1/n from the nearest integer, far
    // beyond the division's rounding. Rows are added and removed whole, so the loops
    // run along memory and vectorise.
    let row = |i: i64| {
        let i = i.clamp(0, h as i64 - 1) as usize;
        &img[i * w..(i + 1) * w]
    };
    let mut acc = vec![0.0f64; w];
    for i in -r..=r {
        for (a, v) in acc.iter_mut().zip(row(i)) {
            *a += f64::from(*v);
        }
    }
    // The column means are whole grey levels; each row of them is finished and its
    // row pass done before the next, so one row of scratch serves. `div` vectorises
    // where a division or `trunc` (without SSE4.1) would not.
    let mut out = take(img.len());
    let ri = r as usize;
    let mut padded = vec![0.0f64; w + 2 * ri + 1];
    for y in 0..h {
        padded[ri..ri + w]
            .iter_mut()
            .zip(&acc)
            .for_each(|(p, a)| *p = f64::from(div(*a)));
        let (first, last) = (padded[ri], padded[ri + w - 1]);
        padded[..ri].fill(first);
        padded[ri + w..].fill(last);
        let mut a: f64 = padded[..size].iter().sum();
        let o = &mut out[y * w..(y + 1) * w];
        for x in 0..w {
            o[x] = div(a) as f32;
            a += padded[x + size] - padded[x];
        }
        let (add, sub) = (row(y as i64 + r + 1), row(y as i64 - r));
        for ((a, p), m) in acc.iter_mut().zip(add).zip(sub) {
            *a += f64::from(*p) - f64::from(*m);
        }
    }
    out
}

/// trackpy's `bandpass(image, noise_size, smoothing_size, threshold)` on an integer
/// frame: the Gaussian low-pass (σ = noise_size) minus the truncated boxcar
/// background (width smoothing_size), values below `threshold` set to 0.
pub fn bandpass(
    img: &[f32],
    w: usize,
    noise_size: f64,
    smoothing_size: usize,
    threshold: f32,
) -> Vec<f32> {
    let background = boxcar_truncated(img, w, smoothing_size);
    let mut out = lowpass(img, w, noise_size);
    for (o, b) in out.iter_mut().zip(&background) {
        let v = *o - b;
        *o = if v >= threshold { v } else { 0.0 };
    }
    give(background);
    out
}

/// Running maximum over the window `[x - left, x + right]` of each row (outside
/// counts as 0, which no band-passed value is below), one offset at a time along the
/// row so the loop vectorises.
#[inline(never)]
fn max_rows(src: &[f32], dst: &mut [f32], w: usize, left: usize, right: usize) {
    for (row, out) in src.chunks_exact(w).zip(dst.chunks_exact_mut(w)) {
        out.copy_from_slice(row);
        for d in 1..=right.min(w - 1) {
            for (o, v) in out[..w - d].iter_mut().zip(&row[d..]) {
                *o = o.max(*v);
            }
        }
        for d in 1..=left.min(w - 1) {
            for (o, v) in out[d..].iter_mut().zip(&row[..w - d]) {
                *o = o.max(*v);
            }
        }
    }
}

/// Row `y` of the running maximum over rows `[y − left, y + right]`, into `out`.
fn max_col_row(src: &[f32], w: usize, y: usize, left: usize, right: usize, out: &mut [f32]) {
    let h = src.len() / w;
    out.fill(0.0);
    for yy in y.saturating_sub(left)..=(y + right).min(h - 1) {
        for (o, v) in out.iter_mut().zip(&src[yy * w..(yy + 1) * w]) {
            *o = o.max(*v);
        }
    }
}

/// Grey dilation with a `size` × `size` square (values ≥ 0), placed as
/// `scipy.ndimage.grey_dilation(size=…)` places it: the maximum over offsets
/// −⌊(size−1)/2⌋ … ⌊size/2⌋, which for an even size reaches one further forward.
pub fn dilate(img: &[f32], w: usize, size: usize) -> Vec<f32> {
    // The maximum is exact, so the order of the passes does not matter: columns
    // first, a row at a time, with one row of scratch.
    let (left, right) = (size.saturating_sub(1) / 2, size / 2);
    let mut out = take(img.len());
    let mut tmp = vec![0.0f32; w];
    for (y, o) in out.chunks_exact_mut(w).enumerate() {
        max_col_row(img, w, y, left, right, &mut tmp);
        max_rows(&tmp, o, w, left, right);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_kernel_is_trackpys() {
        // numpy: exp(-x**2/8) for x in -8..8 normalised (sigma 2, truncate 4).
        let k = gaussian_kernel(2.0, 4.0);
        assert_eq!(k.len(), 17);
        let s: f32 = k.iter().sum();
        assert!((s - 1.0).abs() < 1e-6);
        assert!((k[8] - 0.199_474_65).abs() < 1e-6, "{}", k[8]);
    }

    #[test]
    fn the_truncated_boxcar_is_scipys_on_uint8() {
        // scipy: uniform_filter1d(uint8 [0,0,1,1,1,2,2,2,3,3,250,251], 3, mode='nearest')
        let row = [0.0f32, 0., 1., 1., 1., 2., 2., 2., 3., 3., 250., 251.];
        let b = boxcar_truncated(&row, row.len(), 3);
        assert_eq!(b, [0.0f32, 0., 0., 1., 1., 1., 2., 2., 2., 85., 168., 250.]);
        // Columns first, then rows, each truncated: a single 1 vanishes.
        let mut img = vec![0.0f32; 25];
        img[12] = 8.0;
        let b = boxcar_truncated(&img, 5, 3);
        assert_eq!(b[12], 0.0);
        img[12] = 9.0;
        assert_eq!(boxcar_truncated(&img, 5, 3)[12], 1.0);
    }

    #[test]
    fn lowpass_conserves_the_sum_away_from_edges() {
        let w = 31;
        let mut img = vec![0.0f32; w * w];
        img[15 * w + 15] = 1.0;
        let l = lowpass(&img, w, 1.5);
        let s: f32 = l.iter().sum();
        assert!((s - 1.0).abs() < 1e-5);
        assert!((l[15 * w + 14] - l[15 * w + 16]).abs() < 1e-7);
    }

    #[test]
    fn dilation_spreads_a_peak_over_the_square() {
        let w = 11;
        let mut img = vec![0.0f32; w * w];
        img[5 * w + 5] = 2.0;
        let d = dilate(&img, w, 5);
        assert_eq!(d[3 * w + 7], 2.0);
        assert_eq!(d[2 * w + 5], 0.0);
        // Even sizes as scipy: a peak at 5 spreads over 5 - 3 ..= 5 + 2 (size 6).
        let d = dilate(&img, w, 6);
        assert_eq!(d[5 * w + 2], 2.0);
        assert_eq!(d[5 * w + 7], 2.0);
        assert_eq!(d[5 * w + 8], 0.0);
        assert_eq!(d[5 * w + 1], 0.0);
    }
}
