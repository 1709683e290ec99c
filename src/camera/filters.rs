//! The image filters of trackpy's pre-processing, on `f32` rows: a Gaussian low-pass
//! (zero outside the image, as `scipy.ndimage.correlate1d(mode='constant')`), a boxcar
//! running mean (edge pixels repeated, as `uniform_filter1d(mode='nearest')`, truncated
//! to whole grey levels as scipy does on an integer image), the
//! band-pass that subtracts one from the other, and a grey dilation (running maximum)
//! for the local maxima.

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

/// Correlates every row of `src` (width `w`) with `kernel` (odd length), zero beyond
/// the row's ends, into `dst`.
fn correlate_rows(src: &[f32], dst: &mut [f32], w: usize, kernel: &[f32]) {
    let r = kernel.len() / 2;
    for (row, out) in src.chunks_exact(w).zip(dst.chunks_exact_mut(w)) {
        for (x, o) in out.iter_mut().enumerate() {
            let lo = x.saturating_sub(r);
            let hi = (x + r).min(w - 1);
            let k0 = lo + r - x;
            let mut acc = 0.0f32;
            for (v, k) in row[lo..=hi].iter().zip(&kernel[k0..]) {
                acc += v * k;
            }
            *o = acc;
        }
    }
}

/// Correlates every column with `kernel`, zero beyond the top and bottom; whole rows
/// at a time so the inner loop runs along memory.
fn correlate_cols(src: &[f32], dst: &mut [f32], w: usize, kernel: &[f32]) {
    let h = src.len() / w;
    let r = kernel.len() / 2;
    for y in 0..h {
        let out = &mut dst[y * w..(y + 1) * w];
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
}

/// Gaussian low-pass of σ = `sigma` px (trackpy's `lowpass`, `truncate` 4).
pub fn lowpass(img: &[f32], w: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 {
        return img.to_vec();
    }
    let k = gaussian_kernel(sigma, 4.0);
    let mut tmp = vec![0.0; img.len()];
    let mut out = vec![0.0; img.len()];
    correlate_cols(img, &mut tmp, w, &k);
    correlate_rows(&tmp, &mut out, w, &k);
    out
}

/// trackpy's `boxcar` on an integer image, which scipy's `uniform_filter1d` writes back
/// into the image's integer type: the running mean along columns, truncated, then
/// along rows, truncated (the values are whole numbers, so the sums are exact).
pub fn boxcar_truncated(img: &[f32], w: usize, size: usize) -> Vec<f32> {
    if size <= 1 {
        return img.to_vec();
    }
    let h = img.len() / w;
    let r = (size / 2) as i64;
    let n = size as i64;
    let at = |y: i64, x: usize| img[y.clamp(0, h as i64 - 1) as usize * w + x] as i64;
    let mut cols = vec![0i64; img.len()];
    for x in 0..w {
        let mut acc: i64 = (-r..=r).map(|y| at(y, x)).sum();
        for y in 0..h {
            cols[y * w + x] = acc.div_euclid(n);
            acc += at(y as i64 + r + 1, x) - at(y as i64 - r, x);
        }
    }
    let mut out = vec![0.0f32; img.len()];
    for y in 0..h {
        let row = &cols[y * w..(y + 1) * w];
        let at = |i: i64| row[i.clamp(0, w as i64 - 1) as usize];
        let mut acc: i64 = (-r..=r).map(at).sum();
        for (x, o) in out[y * w..(y + 1) * w].iter_mut().enumerate() {
            *o = acc.div_euclid(n) as f32;
            acc += at(x as i64 + r + 1) - at(x as i64 - r);
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
    out
}

/// Running maximum over the window `[x - left, x + right]` of each row (outside
/// counts as 0, which no band-passed value is below).
fn max_rows(src: &[f32], dst: &mut [f32], w: usize, left: usize, right: usize) {
    for (row, out) in src.chunks_exact(w).zip(dst.chunks_exact_mut(w)) {
        for (x, o) in out.iter_mut().enumerate() {
            let lo = x.saturating_sub(left);
            let hi = (x + right).min(w - 1);
            *o = row[lo..=hi].iter().fold(0.0f32, |m, &v| m.max(v));
        }
    }
}

fn max_cols(src: &[f32], dst: &mut [f32], w: usize, left: usize, right: usize) {
    let h = src.len() / w;
    for y in 0..h {
        let out = &mut dst[y * w..(y + 1) * w];
        out.fill(0.0);
        for yy in y.saturating_sub(left)..=(y + right).min(h - 1) {
            for (o, v) in out.iter_mut().zip(&src[yy * w..(yy + 1) * w]) {
                *o = o.max(*v);
            }
        }
    }
}

/// Grey dilation with a `size` × `size` square (values ≥ 0), placed as
/// `scipy.ndimage.grey_dilation(size=…)` places it: the maximum over offsets
/// −⌊(size−1)/2⌋ … ⌊size/2⌋, which for an even size reaches one further forward.
pub fn dilate(img: &[f32], w: usize, size: usize) -> Vec<f32> {
    let (left, right) = (size.saturating_sub(1) / 2, size / 2);
    let mut tmp = vec![0.0; img.len()];
    let mut out = vec![0.0; img.len()];
    max_rows(img, &mut tmp, w, left, right);
    max_cols(&tmp, &mut out, w, left, right);
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
