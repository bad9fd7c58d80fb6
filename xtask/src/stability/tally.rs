//! Counting helpers: a [`Tally`] per sweep row counts evaluations, NaN, Inf,
//! negative values, panics and property violations, keeps the largest
//! relative error against a reference and a few examples of each problem
//! (the inputs, written so that they can be pasted into a reproduction).

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, PanicHookInfo, catch_unwind};
use std::sync::Mutex;

use serde_json::{Value, json};

/// Examples kept per row (the report lists them; counts stay exact).
pub const MAX_EXAMPLES: usize = 6;

/// References at or below this magnitude are not compared (relative errors
/// of values in and near the subnormal range say nothing about the code).
pub const REFERENCE_FLOOR: f64 = 1e-30;

/// How a value fails the basic checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Finite and >= 0 (-0.0 counts as 0).
    Ok,
    /// Not a number.
    Nan,
    /// +-infinity.
    Inf,
    /// Finite and < 0.
    Negative,
}

/// Classifies `v` for the NaN / Inf / negative columns.
pub fn classify(v: f64) -> Class {
    if v.is_nan() {
        Class::Nan
    } else if v.is_infinite() {
        Class::Inf
    } else if v < 0.0 {
        Class::Negative
    } else {
        Class::Ok
    }
}

/// |got - reference| / |reference|, or `None` when the comparison is not
/// meaningful: the reference is not finite or at most [`REFERENCE_FLOOR`] in
/// magnitude, or `got` is not finite (counted as NaN/Inf elsewhere).
pub fn relative_error(got: f64, reference: f64) -> Option<f64> {
    if !(reference.is_finite() && got.is_finite() && reference.abs() > REFERENCE_FLOOR) {
        return None;
    }
    Some((got - reference).abs() / reference.abs())
}

/// Largest relative and absolute errors of a set of comparisons.
#[derive(Clone, Debug, Default)]
pub struct ErrorStat {
    /// Comparisons made (|reference| above [`REFERENCE_FLOOR`]).
    pub compared: u64,
    /// Largest |x - ref| / |ref|, and where.
    pub max_rel: Option<(f64, String)>,
    /// Largest |x - ref|, and where.
    pub max_abs: Option<(f64, String)>,
}

impl ErrorStat {
    /// Adds one comparison (skipped when not meaningful, see [`relative_error`]).
    pub fn add(&mut self, got: f64, reference: f64, what: impl FnOnce() -> String) {
        let Some(rel) = relative_error(got, reference) else {
            return;
        };
        self.compared += 1;
        let abs = (got - reference).abs();
        let new_rel = self.max_rel.as_ref().is_none_or(|(m, _)| rel > *m);
        let new_abs = self.max_abs.as_ref().is_none_or(|(m, _)| abs > *m);
        if new_rel || new_abs {
            let at = format!("{} = {got:e}, reference {reference:e}", what());
            if new_rel {
                self.max_rel = Some((rel, at.clone()));
            }
            if new_abs {
                self.max_abs = Some((abs, at));
            }
        }
    }

    /// Combines two sets of comparisons.
    pub fn merge(&mut self, other: ErrorStat) {
        self.compared += other.compared;
        if let Some((e, w)) = other.max_rel
            && self.max_rel.as_ref().is_none_or(|(m, _)| e > *m)
        {
            self.max_rel = Some((e, w));
        }
        if let Some((e, w)) = other.max_abs
            && self.max_abs.as_ref().is_none_or(|(m, _)| e > *m)
        {
            self.max_abs = Some((e, w));
        }
    }

    /// As JSON.
    pub fn json(&self) -> Value {
        json!({
            "compared": self.compared,
            "max_rel_error": self.max_rel.as_ref().map(|(e, _)| *e),
            "max_rel_error_at": self.max_rel.as_ref().map(|(_, w)| w.clone()),
            "max_abs_error": self.max_abs.as_ref().map(|(e, _)| *e),
            "max_abs_error_at": self.max_abs.as_ref().map(|(_, w)| w.clone()),
        })
    }
}

/// Counts of one sweep row.
#[derive(Clone, Debug, Default)]
pub struct Tally {
    /// Function calls made.
    pub evaluations: u64,
    /// NaN values returned.
    pub nan: u64,
    /// Infinite values returned.
    pub inf: u64,
    /// Negative values where the quantity must be >= 0.
    pub negative: u64,
    /// Panics caught.
    pub panics: u64,
    /// Violations of the row's other properties (see the row's description).
    pub other: u64,
    /// Errors against the reference over all comparisons.
    pub errors: ErrorStat,
    /// Errors against the reference by case (e.g. by NDF, or index-matched
    /// interfaces apart), so that one stiff corner does not hide the rest.
    pub errors_by_case: BTreeMap<String, ErrorStat>,
    /// The first few problems, with their inputs.
    pub examples: Vec<String>,
    /// Informational counters (statuses, typed errors, ...): not problems.
    pub notes: BTreeMap<String, u64>,
}

impl Tally {
    /// Counts one function call.
    pub fn evaluation(&mut self) {
        self.evaluations += 1;
    }

    /// Counts `n` function calls.
    pub fn evaluations(&mut self, n: u64) {
        self.evaluations += n;
    }

    /// The sum of all problem counts (what must be 0).
    pub fn problems(&self) -> u64 {
        self.nan + self.inf + self.negative + self.panics + self.other
    }

    fn example(&mut self, kind: &str, what: impl FnOnce() -> String) {
        if self.examples.len() < MAX_EXAMPLES {
            self.examples.push(format!("{kind}: {}", what()));
        }
    }

    /// Checks a quantity that must be finite and non-negative; true if it is.
    pub fn value(&mut self, v: f64, what: impl FnOnce() -> String) -> bool {
        match classify(v) {
            Class::Ok => true,
            Class::Nan => {
                self.nan += 1;
                self.example("NaN", what);
                false
            }
            Class::Inf => {
                self.inf += 1;
                self.example("Inf", || format!("{} = {v}", what()));
                false
            }
            Class::Negative => {
                self.negative += 1;
                self.example("negative", || format!("{} = {v:e}", what()));
                false
            }
        }
    }

    /// Checks a quantity that must be finite (any sign); true if it is.
    pub fn finite(&mut self, v: f64, what: impl FnOnce() -> String) -> bool {
        match classify(v) {
            Class::Nan | Class::Inf => self.value(v, what),
            Class::Ok | Class::Negative => true,
        }
    }

    /// Checks every component of a vector quantity that must be finite and
    /// non-negative (an RGB value).
    pub fn values(&mut self, v: [f32; 3], what: impl Fn() -> String) -> bool {
        let mut ok = true;
        for (c, x) in ["r", "g", "b"].iter().zip(v) {
            ok &= self.value(f64::from(x), || format!("{}.{c}", what()));
        }
        ok
    }

    /// Counts a violation of a property unless `holds`; returns `holds`.
    pub fn require(&mut self, holds: bool, what: impl FnOnce() -> String) -> bool {
        if !holds {
            self.other += 1;
            self.example("violation", what);
        }
        holds
    }

    /// Compares `got` with `reference` (see [`relative_error`]) and keeps the
    /// largest relative and absolute errors with their descriptions.
    pub fn compare(&mut self, got: f64, reference: f64, what: impl FnOnce() -> String) {
        self.errors.add(got, reference, what);
    }

    /// [`Tally::compare`], also recorded under `case`.
    pub fn compare_in(&mut self, case: &str, got: f64, reference: f64, what: impl Fn() -> String) {
        if relative_error(got, reference).is_none() {
            return;
        }
        self.errors.add(got, reference, &what);
        if !self.errors_by_case.contains_key(case) {
            self.errors_by_case
                .insert(case.to_string(), ErrorStat::default());
        }
        if let Some(stat) = self.errors_by_case.get_mut(case) {
            stat.add(got, reference, &what);
        }
    }

    /// The largest relative error, if any comparison was made.
    pub fn max_rel_error(&self) -> Option<f64> {
        self.errors.max_rel.as_ref().map(|(e, _)| *e)
    }

    /// Adds one to the informational counter `key`.
    pub fn note(&mut self, key: impl Into<String>) {
        *self.notes.entry(key.into()).or_default() += 1;
    }

    /// Runs `f` and counts a panic (with its message and `what`) instead of
    /// unwinding further. `None` if `f` panicked.
    pub fn guard<R>(
        &mut self,
        what: impl FnOnce() -> String,
        f: impl FnOnce(&mut Tally) -> R,
    ) -> Option<R> {
        match catch_unwind(AssertUnwindSafe(|| f(self))) {
            Ok(r) => Some(r),
            Err(payload) => {
                self.panics += 1;
                let message = payload
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "non-string payload".into());
                let location = last_panic_location().unwrap_or_default();
                self.example("panic", || format!("{} -> \"{message}\"{location}", what()));
                None
            }
        }
    }

    /// Adds the counts of `other` (rows computed in parallel pieces).
    pub fn merge(&mut self, other: Tally) {
        self.evaluations += other.evaluations;
        self.nan += other.nan;
        self.inf += other.inf;
        self.negative += other.negative;
        self.panics += other.panics;
        self.other += other.other;
        self.errors.merge(other.errors);
        for (case, stat) in other.errors_by_case {
            self.errors_by_case.entry(case).or_default().merge(stat);
        }
        for x in other.examples {
            if self.examples.len() < MAX_EXAMPLES {
                self.examples.push(x);
            }
        }
        for (k, n) in other.notes {
            *self.notes.entry(k).or_default() += n;
        }
    }

    /// The counts as JSON.
    pub fn json(&self) -> Value {
        json!({
            "evaluations": self.evaluations,
            "nan": self.nan,
            "inf": self.inf,
            "negative": self.negative,
            "panics": self.panics,
            "other": self.other,
            "errors": self.errors.json(),
            "errors_by_case": self
                .errors_by_case
                .iter()
                .map(|(k, v)| (k.clone(), v.json()))
                .collect::<serde_json::Map<String, Value>>(),
            "examples": self.examples,
            "notes": self.notes,
        })
    }
}

/// One row of the report: what it covers and its counts.
#[derive(Clone, Debug)]
pub struct Row {
    /// Short name (the first column).
    pub name: String,
    /// What is evaluated, over which domain.
    pub covers: String,
    /// What the `other` column counts for this row.
    pub other: &'static str,
    /// What the relative error is measured against (`None`: no reference).
    pub reference: Option<&'static str>,
    /// The counts.
    pub tally: Tally,
    /// Wall-clock seconds the row took.
    pub seconds: f64,
}

/// Where the last panic happened (recorded by the quiet hook), as
/// " at file:line", taken once.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

fn last_panic_location() -> Option<String> {
    LAST_PANIC.lock().ok()?.take()
}

type Hook = Box<dyn Fn(&PanicHookInfo<'_>) + Sync + Send + 'static>;

/// While alive, panics print nothing (the sweeps count them) and only
/// record their location; the previous hook is restored on drop.
pub struct QuietPanics {
    previous: Option<Hook>,
}

impl QuietPanics {
    /// Installs the quiet hook.
    pub fn install() -> Self {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(|info| {
            if let (Some(l), Ok(mut slot)) = (info.location(), LAST_PANIC.lock()) {
                *slot = Some(format!(" at {}:{}", l.file(), l.line()));
            }
        }));
        Self {
            previous: Some(previous),
        }
    }
}

impl Drop for QuietPanics {
    fn drop(&mut self) {
        if let Some(previous) = self.previous.take() {
            std::panic::set_hook(previous);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classify_separates_the_columns() {
        assert_eq!(classify(0.0), Class::Ok);
        assert_eq!(classify(-0.0), Class::Ok);
        assert_eq!(classify(1e300), Class::Ok);
        assert_eq!(classify(f64::MIN_POSITIVE / 4.0), Class::Ok);
        assert_eq!(classify(f64::NAN), Class::Nan);
        assert_eq!(classify(f64::INFINITY), Class::Inf);
        assert_eq!(classify(f64::NEG_INFINITY), Class::Inf);
        assert_eq!(classify(-1e-300), Class::Negative);
        assert_eq!(classify(f64::from(f32::NAN)), Class::Nan);
    }

    #[test]
    fn value_counts_each_kind_once_and_keeps_examples() {
        let mut t = Tally::default();
        assert!(t.value(1.0, || "x".into()));
        assert!(!t.value(f64::NAN, || "a".into()));
        assert!(!t.value(f64::INFINITY, || "b".into()));
        assert!(!t.value(-2.0, || "c".into()));
        assert!(t.finite(-2.0, || "d".into()));
        assert!(!t.finite(f64::NEG_INFINITY, || "e".into()));
        assert_eq!((t.nan, t.inf, t.negative, t.other), (1, 2, 1, 0));
        assert_eq!(t.problems(), 4);
        assert_eq!(t.examples.len(), 4);
        assert!(t.examples[0].starts_with("NaN: a"), "{:?}", t.examples);
        assert!(t.examples[2].contains("c = -2e0"), "{:?}", t.examples);
        // The rgb helper names the channel.
        assert!(!t.values([0.0, f32::NAN, 1.0], || "f".into()));
        assert_eq!(t.nan, 2);
        assert!(t.examples[4].contains("f.g"), "{:?}", t.examples);
        // Examples are capped, counts are not.
        for _ in 0..20 {
            t.require(false, || "p".into());
        }
        assert_eq!(t.other, 20);
        assert_eq!(t.examples.len(), MAX_EXAMPLES);
    }

    #[test]
    fn relative_error_skips_meaningless_comparisons() {
        assert_eq!(relative_error(1.5, 1.0), Some(0.5));
        assert_eq!(relative_error(-1.0, -2.0), Some(0.5));
        assert_eq!(relative_error(1.0, 0.0), None);
        assert_eq!(relative_error(1.0, 1e-31), None);
        assert_eq!(relative_error(f64::NAN, 1.0), None);
        assert_eq!(relative_error(1.0, f64::INFINITY), None);
        let mut t = Tally::default();
        t.compare(1.0, 1.0, || "a".into());
        t.compare(1.1, 1.0, || "b".into());
        t.compare(1.05, 1.0, || "c".into());
        t.compare(5.0, 0.0, || "d".into());
        assert_eq!(t.errors.compared, 3);
        let (e, at) = t.errors.max_rel.clone().unwrap();
        assert!((e - 0.1).abs() < 1e-12 && at.starts_with("b ="), "{at}");
        // Absolute and relative maxima can come from different comparisons.
        t.compare(1e-20, 2e-20, || "tiny".into());
        t.compare(1001.0, 1000.0, || "big".into());
        assert!(t.errors.max_rel.as_ref().unwrap().1.starts_with("tiny"));
        assert!(t.errors.max_abs.as_ref().unwrap().1.starts_with("big"));
        // Cases keep their own maxima and feed the overall one.
        t.compare_in("x", 3.0, 1.0, || "case x".into());
        t.compare_in("y", 1.0, 0.0, || "skipped".into());
        assert_eq!(t.max_rel_error(), Some(2.0));
        assert_eq!(t.errors_by_case.len(), 1);
        assert_eq!(t.errors_by_case["x"].compared, 1);
    }

    #[test]
    fn guard_counts_panics_and_merge_adds_up() {
        let _quiet = QuietPanics::install();
        let mut a = Tally::default();
        assert_eq!(a.guard(|| "ok".into(), |_| 3), Some(3));
        let r: Option<()> = a.guard(|| "boom".into(), |_| panic!("expected {}", 7));
        assert!(r.is_none());
        assert_eq!(a.panics, 1);
        assert!(a.examples[0].contains("boom") && a.examples[0].contains("expected 7"));
        assert!(a.examples[0].contains("tally.rs"), "{:?}", a.examples);
        a.note("status");
        a.compare(2.0, 1.0, || "x".into());
        let mut b = Tally::default();
        b.evaluations(5);
        b.value(f64::NAN, || "n".into());
        b.note("status");
        b.compare(1.5, 1.0, || "y".into());
        a.merge(b);
        assert_eq!((a.evaluations, a.nan, a.panics), (5, 1, 1));
        assert_eq!(a.notes["status"], 2);
        assert_eq!(a.max_rel_error(), Some(1.0));
        assert_eq!(a.errors.compared, 2);
        assert_eq!(a.problems(), 2);
        assert_eq!(a.json()["nan"], 1);
    }
}
