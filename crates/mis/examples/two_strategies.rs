//! Multiple importance sampling of a 1D integral with two strategies.
//!
//! The integrand f(x) = 1 + 30 exp(-((x - 0.8) / 0.02)^2) on [0, 1] has a
//! broad part, which uniform sampling estimates well, and a narrow peak,
//! which sampling the peak's Gaussian estimates well. Each strategy alone has
//! a large variance somewhere; one sample of each, weighted by the balance or
//! power heuristic (Veach 1997, ch. 9), has a small one.
//!
//! Run with `cargo run -p rlt-mis --example two_strategies`.

use mis::{balance_heuristic, power_heuristic};
use std::f64::consts::PI;

const CENTRE: f64 = 0.8;
const WIDTH: f64 = 0.02;

fn f(x: f64) -> f64 {
    1.0 + 30.0 * (-((x - CENTRE) / WIDTH).powi(2)).exp()
}

/// Density of the peak's Gaussian (its mass outside [0, 1] is negligible).
fn peak_pdf(x: f64) -> f64 {
    let sigma = WIDTH / 2f64.sqrt();
    (-((x - CENTRE) / WIDTH).powi(2)).exp() / (sigma * (2.0 * PI).sqrt())
}

/// A Gaussian sample from two uniforms (Box-Muller).
fn sample_peak(u1: f64, u2: f64) -> f64 {
    let sigma = WIDTH / 2f64.sqrt();
    CENTRE + sigma * (-2.0 * (1.0 - u1).ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// A small xorshift generator: the example has no dependencies.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The weights of the uniform and the peak sample of a point with densities
/// (p_uniform, p_peak) under each strategy.
type Weights = fn(f64, f64) -> (f64, f64);

/// One estimate from one sample of each strategy, each weighted by `weights`.
fn estimate(rng: &mut Rng, weights: Weights) -> f64 {
    let x = rng.uniform();
    let uniform = weights(1.0, peak_pdf(x)).0 * f(x);
    let x = sample_peak(rng.uniform(), rng.uniform());
    let peak = if (0.0..=1.0).contains(&x) {
        weights(1.0, peak_pdf(x)).1 * f(x) / peak_pdf(x)
    } else {
        0.0
    };
    uniform + peak
}

fn main() {
    let exact = 1.0 + 30.0 * WIDTH * PI.sqrt(); // the peak lies well inside [0, 1]
    let strategies: [(&str, Weights); 4] = [
        ("uniform alone", |_, _| (1.0, 0.0)),
        ("peak alone", |_, _| (0.0, 1.0)),
        ("balance heuristic", |u, p| {
            (balance_heuristic(u, p), balance_heuristic(p, u))
        }),
        ("power heuristic", |u, p| {
            (power_heuristic(u, p), power_heuristic(p, u))
        }),
    ];
    println!("exact integral {exact:.5}; 100000 estimates, one sample of each strategy:");
    for (name, weights) in strategies {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let n = 100_000;
        let values: Vec<f64> = (0..n).map(|_| estimate(&mut rng, weights)).collect();
        let mean = values.iter().sum::<f64>() / n as f64;
        let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        println!("  {name:<18} mean {mean:.5}  variance {variance:10.4}");
    }
    println!("(the peak alone misses most of the broad part: its rare far samples carry it)");
}
