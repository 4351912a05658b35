//! Least-squares fits of the convergence and growth tests (orders of convergence, envelope
//! growth rates), stated once: included with `#[path]` by the tests that fit.
#![allow(dead_code)]

/// The least-squares slope of `y` against `x` over the points `(x, y)`.
pub fn slope(pts: &[(f64, f64)]) -> f64 {
    let n = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx) * (p.1 - my), a.1 + (p.0 - mx).powi(2))
    });
    sxy / sxx
}

/// The least-squares slope of log(err) against log(dt) over the points `(dt, err)`.
pub fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|(x, y)| (x.ln(), y.ln())).collect();
    slope(&logs)
}

/// Growth rate of the envelope of `|u − u_eq|` sampled at times `t`: least squares of ln(peak)
/// over `[t_a, t_b]`, each peak's height refined by a parabola.
pub fn growth(t: &[f64], u: &[f64], u_eq: f64, t_a: f64, t_b: f64) -> f64 {
    let x: Vec<f64> = u.iter().map(|u| (u - u_eq).abs()).collect();
    let mut pts = vec![];
    for i in 1..x.len() - 1 {
        if x[i] > x[i - 1] && x[i] >= x[i + 1] && t[i] >= t_a && t[i] <= t_b {
            let (a, b, c) = (x[i - 1], x[i], x[i + 1]);
            let den = a - 2.0 * b + c;
            let peak = if den != 0.0 {
                b - 0.125 * (a - c).powi(2) / den
            } else {
                b
            };
            pts.push((t[i], peak.ln()));
        }
    }
    slope(&pts)
}
