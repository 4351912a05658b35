//! # vibrobar-py
//!
//! The native module `vibrobar._vibrobar` of the Python package (`python/vibrobar`). Every
//! computation is the library's own, called the way the command line calls it, so the numbers
//! are the CLI's bit for bit: the scenario is `vibrobar-scenario`'s, batches run on the core's
//! `Runner`/`Batch` (its thread pool), tables use `vibrobar-io`'s CSV schemas (column names and
//! the text of a row).
//!
//! Long calls release the GIL: the work runs on a worker thread while the calling thread, every
//! [`POLL`], takes the GIL to check for signals (Ctrl-C raises the core runner's cancel flag, and
//! the call raises `KeyboardInterrupt` once the runs in flight end) and to report progress to a
//! Python callback, which therefore always runs on the caller's thread. A panic anywhere becomes
//! a `RuntimeError`.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{IntoPyDict, PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;
use vibrobar_core::analysis::case::{run_case, Sampler};
use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::analysis::ensemble::{run_ensemble, EnsembleParams, IcRanges};
use vibrobar_core::analysis::lyapunov::{max_lyapunov, max_lyapunov_modal, LyapunovParams};
use vibrobar_core::analysis::lyapunov_spectrum::{
    lyapunov_spectrum as core_spectrum, SpectrumParams,
};
use vibrobar_core::analysis::map::{compute_point, compute_point_from, Axis, Grid, GridAxis};
use vibrobar_core::analysis::map::{GridPoint, MapSpec};
use vibrobar_core::analysis::poincare::{bifurcation, BifurcationSpec, Stroboscope};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::sweep::sweep_audited_at;
use vibrobar_core::analysis::{BatchError, Runner, SolidRatios, SweepBase};
use vibrobar_core::params::BarModel;
use vibrobar_core::solver::{modal_run_by_name, solver_by_name, Event, EventKind, Fanout};
use vibrobar_core::solver::{Segment, SOLVER_NAMES};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem};
use vibrobar_core::{limits, Frequency, Observer, Solver, System};
use vibrobar_io::csv::{self as iocsv, Schema, Value};
use vibrobar_scenario::Scenario;

mod two_planes;
use two_planes::{
    two_plane_continuation, two_plane_lyapunov, two_plane_lyapunov_spectrum, two_plane_orbit,
    two_plane_poincare, two_plane_run, two_plane_table,
};

/// How often the calling thread checks for Ctrl-C and reports progress while a call runs.
const POLL: Duration = Duration::from_millis(100);

// ---------------------------------------------------------------------------------------------
// errors

/// An input error (a field and its allowed range, as the command line says it): `ValueError`,
/// or `TypeError` when a value has the wrong type.
fn input_error(e: impl std::fmt::Display) -> PyErr {
    let msg = e.to_string();
    if msg.contains("invalid type") {
        PyTypeError::new_err(msg)
    } else {
        PyValueError::new_err(msg)
    }
}

fn anyhow_input(e: anyhow::Error) -> PyErr {
    input_error(format!("{e:#}"))
}

/// An error of the computation itself (a run that failed).
fn run_error(e: impl std::fmt::Display) -> PyErr {
    PyRuntimeError::new_err(e.to_string())
}

fn batch_error<E: std::fmt::Display>(e: BatchError<E>) -> PyErr {
    match e {
        BatchError::Param(p) => input_error(p),
        other => run_error(other),
    }
}

// ---------------------------------------------------------------------------------------------
// the worker and its watcher

/// What a job sees: the cancel flag (raised on Ctrl-C or a failing progress callback) and the
/// progress sink (`done`, `total` over its runs).
struct Ctl {
    cancel: AtomicBool,
    done: AtomicUsize,
    total: AtomicUsize,
}

impl Ctl {
    fn progress(&self, done: usize, total: usize) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(done, Ordering::Relaxed);
    }

    fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// Run `job` with the GIL released on a worker thread; the caller's thread polls for signals and
/// calls `progress(done, total)` whenever the count moved. A signal's exception (or the
/// callback's) wins over the job's result, once the job has stopped.
fn detached<R: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    job: impl FnOnce(&Ctl) -> PyResult<R> + Send,
) -> PyResult<R> {
    let ctl = Ctl {
        cancel: AtomicBool::new(false),
        done: AtomicUsize::new(0),
        total: AtomicUsize::new(0),
    };
    let cb: Option<Py<PyAny>> = progress.map(|p| p.clone().unbind());
    let (result, interrupt) = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::channel::<()>();
            let ctl = &ctl;
            let worker = s.spawn(move || {
                let r = catch_unwind(AssertUnwindSafe(|| job(ctl)));
                let _ = tx.send(());
                r
            });
            let mut interrupt: Option<PyErr> = None;
            let mut shown = (usize::MAX, usize::MAX);
            let mut report = |interrupt: &mut Option<PyErr>| {
                Python::attach(|py| {
                    if interrupt.is_none() {
                        if let Err(e) = py.check_signals() {
                            ctl.cancel.store(true, Ordering::Relaxed);
                            *interrupt = Some(e);
                        }
                    }
                    let now = (
                        ctl.done.load(Ordering::Relaxed),
                        ctl.total.load(Ordering::Relaxed),
                    );
                    if let (Some(cb), None, true) = (&cb, &interrupt, now.1 > 0 && now != shown) {
                        shown = now;
                        if let Err(e) = cb.call1(py, now) {
                            ctl.cancel.store(true, Ordering::Relaxed);
                            *interrupt = Some(e);
                        }
                    }
                })
            };
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(POLL) {
                report(&mut interrupt);
            }
            report(&mut interrupt);
            (worker.join(), interrupt)
        })
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    match result {
        Ok(Ok(r)) => r,
        Ok(Err(p)) | Err(p) => Err(PyRuntimeError::new_err(format!(
            "internal error (a panic in vibrobar; please report it): {}",
            p.downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("no message")
        ))),
    }
}

/// A cancelled batch is the interrupt the watcher already holds; any other error stays.
fn batch_result<T, E: std::fmt::Display>(r: Result<T, BatchError<E>>) -> PyResult<T> {
    match r {
        Err(BatchError::Cancelled { .. }) => Err(PyKeyboardInterrupt::new_err("cancelled")),
        other => other.map_err(batch_error),
    }
}

/// Items per chunk of a batch without a cancel flag of its own (bifurcation, ensemble): a few
/// runs per worker, so Ctrl-C is seen after about one run's time.
fn chunk_len() -> usize {
    2 * std::thread::available_parallelism().map_or(1, |n| n.get())
}

// ---------------------------------------------------------------------------------------------
// scenario

/// Section names of a scenario file, in the order flat keywords are looked up.
const SECTIONS: [&str; 10] = [
    "damper",
    "contact",
    "forcing",
    "run",
    "initial",
    "sweep",
    "bar",
    "solid_bar",
    "beam",
    "cutting",
];

/// Keys a section accepts but its serialisation leaves out when they are absent (`Option`s and
/// the alternative forcing frequency). Anything else unknown is refused by the scenario's own
/// `deny_unknown_fields`, with the valid names.
const OPTIONAL_KEYS: [(&str, &str); 9] = [
    ("damper", "friction_force_n"),
    ("forcing", "frequency_ratio"),
    ("forcing", "omega_rad_s"),
    ("beam", "modes"),
    ("beam", "force_position_m"),
    ("beam", "response_position_m"),
    ("beam", "tip_mass"),
    ("beam", "cavity_section"),
    ("beam", "fe_elements"),
];

/// The scenario as a TOML table in the file's layout; a `[beam]` or `[[modes]]` scenario
/// without `[bar]` and `[solid_bar]` (they do not apply to it and a file may not give both).
fn scenario_table(s: &Scenario) -> PyResult<toml::Table> {
    let mut t = match toml::Value::try_from(s).map_err(run_error)? {
        toml::Value::Table(t) => t,
        _ => return Err(run_error("a scenario serialises to a table")),
    };
    if s.beam.is_some() || s.modes.is_some() {
        t.remove("bar");
        t.remove("solid_bar");
    }
    Ok(t)
}

/// Every keyword name valid for `t`: section names and the keys of each section.
fn known_keys(t: &toml::Table) -> Vec<(Option<&'static str>, String)> {
    let mut v: Vec<(Option<&'static str>, String)> =
        SECTIONS.iter().map(|s| (None, s.to_string())).collect();
    v.push((None, "gravity_m_s2".into()));
    let beam_default = toml::Value::try_from(Beam::default()).ok();
    let bar_default = toml::Value::try_from(vibrobar_core::Bar::PAPER_CAVITY).ok();
    // `[contact]` is left out of the scenario's TOML for the default law: its keys still apply.
    let contact_default = toml::Value::try_from(vibrobar_core::Contact::default()).ok();
    for sec in SECTIONS {
        let keys: Vec<String> = match (t.get(sec), sec) {
            (Some(toml::Value::Table(st)), _) => st.keys().cloned().collect(),
            // A lumped scenario still takes `[beam]` keys through `beam=dict(...)`.
            (None, "beam") => beam_default
                .as_ref()
                .and_then(|b| b.as_table())
                .map(|b| b.keys().cloned().collect())
                .unwrap_or_default(),
            (None, "contact") => contact_default
                .as_ref()
                .and_then(|c| c.as_table())
                .map(|c| c.keys().cloned().collect())
                .unwrap_or_default(),
            // And a beam scenario knows the lumped bar's keys, to say where they belong.
            (None, "bar" | "solid_bar") => bar_default
                .as_ref()
                .and_then(|b| b.as_table())
                .map(|b| b.keys().cloned().collect())
                .unwrap_or_default(),
            _ => Vec::new(),
        };
        for k in keys {
            v.push((Some(sec), k));
        }
    }
    for (sec, k) in OPTIONAL_KEYS {
        if !v.iter().any(|(s, kk)| *s == Some(sec) && kk == k) {
            v.push((Some(sec), k.to_string()));
        }
    }
    v
}

/// Levenshtein distance (keyword suggestions).
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The valid name nearest to `name`, if it is near enough to be a likely typo; a name that
/// starts with `name` (`gap` → `gap_m`) wins a tie.
fn nearest<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .map(|c| (edit_distance(name, c), !c.starts_with(name), c))
        .filter(|(d, _, c)| *d <= 2.max(c.len() / 3))
        .min_by_key(|(d, p, _)| (*d, *p))
        .map(|(_, _, c)| c)
}

/// The last line of a TOML/serde error: what was wrong with the value (its line and column
/// refer to text the caller never saw).
fn serde_message(e: &anyhow::Error) -> String {
    let full = format!("{e:#}");
    let msg = full
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or(&full)
        .trim()
        .to_string();
    // "unknown field `x`, expected one of `a`, `b`": add the nearest valid name.
    if let Some(rest) = msg.split("unknown field `").nth(1) {
        let mut parts = rest.split('`');
        if let Some(bad) = parts.next() {
            let valid: Vec<&str> = parts.skip(1).step_by(2).collect();
            if let Some(n) = nearest(bad, valid.into_iter()) {
                return format!("{msg}; did you mean `{n}`?");
            }
        }
    }
    msg
}

/// A Python value as TOML (`None` → `None`: the key is removed, an optional field left unset).
fn to_toml(key: &str, v: &Bound<'_, PyAny>) -> PyResult<Option<toml::Value>> {
    if v.is_none() {
        return Ok(None);
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(Some(toml::Value::Boolean(v.extract()?)));
    }
    if v.is_instance_of::<PyInt>() {
        return match v.extract::<i64>() {
            Ok(i) => Ok(Some(toml::Value::Integer(i))),
            Err(_) => Err(PyValueError::new_err(format!(
                "{key}: integer {v} is too large"
            ))),
        };
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Some(toml::Value::Float(v.extract()?)));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Some(toml::Value::String(v.extract()?)));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!("{key}: dictionary keys must be strings"))
            })?;
            if let Some(x) = to_toml(&format!("{key}.{k}"), &x)? {
                t.insert(k, x);
            }
        }
        return Ok(Some(toml::Value::Table(t)));
    }
    // NumPy scalars and 0-d arrays are numbers; lists, tuples and 1-d arrays are arrays.
    if v.hasattr("__float__")? && !v.hasattr("__len__")? {
        return Ok(Some(toml::Value::Float(v.extract::<f64>().map_err(
            |_| PyTypeError::new_err(format!("{key}: expected a number, got {v}")),
        )?)));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() || v.hasattr("tolist")? {
        let items = if v.hasattr("tolist")? {
            v.call_method0("tolist")?
        } else {
            v.clone()
        };
        let mut a = Vec::new();
        for x in items.try_iter()? {
            let x = x?;
            match to_toml(key, &x)? {
                Some(x) => a.push(x),
                None => {
                    return Err(PyTypeError::new_err(format!(
                        "{key}: None is not allowed inside a list"
                    )))
                }
            }
        }
        return Ok(Some(toml::Value::Array(a)));
    }
    Err(PyTypeError::new_err(format!(
        "{key}: expected a number, string, bool, list or dict, got {}",
        v.get_type().name()?
    )))
}

/// A TOML value as Python.
fn from_toml<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(from_toml(py, x)?)?;
            }
            l.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, from_toml(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// Merge `v` into `slot`: tables key by key (recursively), anything else replaces.
fn merge(slot: &mut toml::Table, key: &str, v: Option<toml::Value>) {
    match (slot.get_mut(key), v) {
        (_, None) => {
            slot.remove(key);
        }
        (Some(toml::Value::Table(old)), Some(toml::Value::Table(new))) => {
            for (k, x) in new {
                merge(old, &k, Some(x));
            }
        }
        (_, Some(x)) => {
            slot.insert(key.to_string(), x);
        }
    }
}

/// `s` with keyword overrides: a section name takes a dict (merged into the section; `beam=None`
/// goes back to the lumped bar), any other keyword is a field of the one section that has it
/// (`gap_m` → `[damper]`, `solver` → `[run]`). The result is read back as a scenario file and
/// validated, so errors name the field and its allowed range as the CLI does.
fn with_overrides(s: &Scenario, kw: Option<&Bound<'_, PyDict>>) -> PyResult<Scenario> {
    let Some(kw) = kw.filter(|k| !k.is_empty()) else {
        s.validate().map_err(anyhow_input)?;
        return Ok(s.clone());
    };
    let mut t = scenario_table(s)?;
    let known = known_keys(&t);
    let mut gap_given = false;
    let mut gaps_given = false;
    let mut bar_given = false;
    let mut beam_given = false;
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        let val = to_toml(&key, &v)?;
        if SECTIONS.contains(&key.as_str()) {
            if !matches!(val, None | Some(toml::Value::Table(_))) {
                return Err(PyTypeError::new_err(format!(
                    "{key}: a section takes a dict of its fields, e.g. {key}=dict(...)"
                )));
            }
            bar_given |= key == "bar" || key == "solid_bar";
            beam_given |= key == "beam";
            if let Some(toml::Value::Table(st)) = &val {
                gap_given |= key == "damper" && st.contains_key("gap_m");
                gaps_given |= key == "sweep" && st.contains_key("gaps_m");
            }
            merge(&mut t, &key, val);
            continue;
        }
        if key == "gravity_m_s2" {
            merge(&mut t, &key, val);
            continue;
        }
        let all_owners: Vec<&'static str> = known
            .iter()
            .filter(|(sec, k)| sec.is_some() && *k == key)
            .filter_map(|(sec, _)| *sec)
            .collect();
        // Flat names reach the sections this scenario has (a beam's or a lumped bar's).
        let owners: Vec<&'static str> = all_owners
            .iter()
            .copied()
            .filter(|sec| t.contains_key(*sec) || *sec == "damper" || *sec == "forcing")
            .collect();
        let sec = match owners.as_slice() {
            [one] => *one,
            [] if !all_owners.is_empty() => {
                return Err(PyTypeError::new_err(format!(
                    "`{key}` is a field of {}, which this scenario does not have ({}): give it as {}=dict({key}=...){}",
                    all_owners
                        .iter()
                        .map(|s| format!("[{s}]"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    if t.contains_key("beam") { "a [beam]" } else { "the lumped bar" },
                    all_owners[0],
                    if all_owners[0] == "beam" { ", or start from Scenario.paper_beam()" } else { "" }
                )))
            }
            [] => {
                let hint = nearest(&key, known.iter().map(|(_, k)| k.as_str()))
                    .map(|n| format!("; did you mean `{n}`?"))
                    .unwrap_or_default();
                let mut names: Vec<&str> = known.iter().map(|(_, k)| k.as_str()).collect();
                names.sort_unstable();
                names.dedup();
                return Err(PyTypeError::new_err(format!(
                    "unknown scenario keyword `{key}`{hint} (valid: {})",
                    names.join(", ")
                )));
            }
            many => {
                return Err(PyTypeError::new_err(format!(
                    "`{key}` is a field of several sections ({}): give it as {}=dict({key}=...)",
                    many.iter()
                        .map(|s| format!("[{s}]"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    many[0]
                )))
            }
        };
        gap_given |= sec == "damper" && key == "gap_m";
        gaps_given |= sec == "sweep" && key == "gaps_m";
        let section = t
            .entry(sec.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        if let toml::Value::Table(st) = section {
            // One frequency: a ratio replaces an ω and the other way round.
            match key.as_str() {
                "frequency_ratio" => {
                    st.remove("omega_rad_s");
                }
                "omega_rad_s" => {
                    st.remove("frequency_ratio");
                }
                _ => {}
            }
            merge(st, &key, val);
        }
    }
    if beam_given && t.contains_key("beam") && !bar_given {
        // A beam given here replaces the lumped bar (which the scenario carried by default).
        t.remove("bar");
        t.remove("solid_bar");
    }
    // As in a file: a gap given without a sweep's gaps is the gap swept.
    if gap_given && !gaps_given {
        if let Some(g) = t.get("damper").and_then(|d| d.get("gap_m")).cloned() {
            if let Some(toml::Value::Table(sw)) = t.get_mut("sweep") {
                sw.insert("gaps_m".into(), toml::Value::Array(vec![g]));
            }
        }
    }
    let text = toml::to_string(&t).map_err(run_error)?;
    let out = Scenario::from_toml(&text).map_err(|e| {
        // Name the keyword whose value was refused (not the line of generated text).
        let culprit = kw.iter().find_map(|(k, v)| {
            if kw.len() == 1 {
                return k.extract::<String>().ok();
            }
            let one = PyDict::new(kw.py());
            one.set_item(&k, v).ok()?;
            let k: String = k.extract().ok()?;
            with_overrides(s, Some(&one)).err().map(|_| k)
        });
        let msg = serde_message(&e);
        match culprit {
            Some(k) => input_error(format!("{k}: {msg}")),
            None => input_error(msg),
        }
    })?;
    out.cutting_solver().map_err(anyhow_input)?;
    if solver_by_name(&out.run.solver, &out.settings()).is_none() {
        return Err(PyValueError::new_err(format!(
            "run.solver = {:?} is not a solver; allowed: {}",
            out.run.solver,
            SOLVER_NAMES.join(", ")
        )));
    }
    out.validate().map_err(anyhow_input)?;
    Ok(out)
}

/// A simulation scenario: the bar (lumped or a `[beam]`), the ball, the forcing, the run
/// settings, the initial state and the sweep range, in SI units. Immutable: keyword overrides
/// make a new scenario.
#[pyclass(module = "vibrobar._vibrobar", name = "Scenario", frozen, eq)]
#[derive(Clone, PartialEq)]
struct PyScenario {
    inner: Scenario,
}

impl PyScenario {
    /// The scenario for the one-plane Python function `command`: a scenario with `[two_plane]`
    /// is refused (rather than running the one-plane model silently).
    fn for_command(&self, command: &str) -> PyResult<&Scenario> {
        if self.inner.two_plane.is_some() {
            return Err(PyValueError::new_err(format!(
                "vibrobar.{command} does not run a scenario with [two_plane] (the bar that bends \
                 in two planes runs with vibrobar.{}, and vibrobar.two_plane at one design \
                 point); remove [two_plane] for the one-plane model",
                PY_TWO_PLANE_FUNCTIONS.join(", vibrobar.")
            )));
        }
        Ok(&self.inner)
    }
}

/// The Python functions that run a scenario with `[two_plane]` (through the native functions of
/// [`two_planes`], which never call [`PyScenario::for_command`]).
const PY_TWO_PLANE_FUNCTIONS: [&str; 9] = [
    "two_plane_run",
    "sweep",
    "ensemble",
    "map",
    "poincare",
    "lyapunov",
    "lyapunov_spectrum",
    "orbit",
    "continuation",
];

#[pymethods]
impl PyScenario {
    /// The paper's scenario (lumped bar), with keyword overrides.
    #[staticmethod]
    #[pyo3(signature = (**overrides))]
    fn paper(overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        Ok(PyScenario {
            inner: with_overrides(&Scenario::paper(), overrides)?,
        })
    }

    /// The paper's bar as a clamped–free Euler–Bernoulli beam (`[beam]` with its defaults),
    /// with keyword overrides (`modes=3`, `beam=dict(length_m=0.2)`).
    #[staticmethod]
    #[pyo3(signature = (**overrides))]
    fn paper_beam(overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let s = Scenario::from_toml("[beam]\n").map_err(anyhow_input)?;
        Ok(PyScenario {
            inner: with_overrides(&s, overrides)?,
        })
    }

    /// Read a scenario file (TOML, SI units), with keyword overrides.
    #[staticmethod]
    #[pyo3(signature = (path, **overrides))]
    fn from_toml(
        path: std::path::PathBuf,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let text = std::fs::read_to_string(&path).map_err(|e| {
            pyo3::exceptions::PyOSError::new_err(format!(
                "cannot read scenario file {}: {e}",
                path.display()
            ))
        })?;
        let s = Scenario::from_toml(&text)
            .map_err(|e| input_error(format!("invalid scenario file {}: {e:#}", path.display())))?;
        Ok(PyScenario {
            inner: with_overrides(&s, overrides)?,
        })
    }

    /// Parse scenario TOML text, with keyword overrides.
    #[staticmethod]
    #[pyo3(signature = (text, **overrides))]
    fn from_toml_str(text: &str, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let s = Scenario::from_toml(text).map_err(anyhow_input)?;
        Ok(PyScenario {
            inner: with_overrides(&s, overrides)?,
        })
    }

    /// A copy with keyword overrides.
    #[pyo3(signature = (**overrides))]
    fn replace(&self, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        Ok(PyScenario {
            inner: with_overrides(&self.inner, overrides)?,
        })
    }

    /// The scenario as TOML text; `Scenario.from_toml_str` reads it back as the same scenario.
    fn to_toml(&self) -> PyResult<String> {
        toml::to_string(&scenario_table(&self.inner)?).map_err(run_error)
    }

    /// The scenario as nested dicts, section → field → value (the TOML layout).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        from_toml(py, &toml::Value::Table(scenario_table(&self.inner)?))
    }

    /// Solver name (`[run] solver`).
    #[getter]
    fn solver(&self) -> String {
        self.inner.run.solver.clone()
    }

    /// Total clearance of the ball in m (`[damper] gap_m`).
    #[getter]
    fn gap_m(&self) -> f64 {
        self.inner.damper.gap_m
    }

    /// Forcing frequency as Ω/ω₁ of the bar with the cavity.
    #[getter]
    fn frequency_ratio(&self) -> PyResult<f64> {
        self.inner.frequency_ratio().map_err(anyhow_input)
    }

    /// True for a scenario with `[two_plane]` (the bar that bends in two planes).
    #[getter]
    fn is_two_plane(&self) -> bool {
        self.inner.two_plane.is_some()
    }

    /// True for a `[beam]` scenario (the bar's modes), false for the lumped bar.
    #[getter]
    fn is_beam(&self) -> bool {
        self.inner.beam.is_some()
    }

    fn __repr__(&self) -> PyResult<String> {
        Ok(format!(
            "Scenario.from_toml_str('''\n{}''')",
            self.to_toml()?
        ))
    }
}

// ---------------------------------------------------------------------------------------------
// tables

/// Rows of `schema` as columns: name → float64 array (empty optional fields NaN), int64 array
/// (counts) or list of str (text); with the CSV text of the rows (header first), formatted by the
/// same schema as the CLI's files.
fn columns<'py>(
    py: Python<'py>,
    schema: &Schema,
    rows: &[Vec<Value>],
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let d = PyDict::new(py);
    for (j, c) in schema.columns.iter().enumerate() {
        let col = rows.iter().map(|r| &r[j]);
        match (c.format, rows.first().map(|r| &r[j])) {
            (iocsv::Format::Count, _) => {
                let v: Vec<i64> = col
                    .map(|x| match x {
                        Value::U(n) => i64::try_from(*n).unwrap_or(i64::MAX),
                        _ => 0,
                    })
                    .collect();
                d.set_item(c.name.as_ref(), v.into_pyarray(py))?;
            }
            (iocsv::Format::Text, _) | (_, Some(Value::S(_))) => {
                let v: Vec<String> = col.map(|x| x.s().to_string()).collect();
                d.set_item(c.name.as_ref(), PyList::new(py, v)?)?;
            }
            _ => {
                let v: Vec<f64> = col.map(Value::f).collect();
                d.set_item(c.name.as_ref(), v.into_pyarray(py))?;
            }
        }
    }
    let mut csv = schema.header();
    csv.push('\n');
    for r in rows {
        schema.format_into(r, &mut csv);
        csv.push('\n');
    }
    Ok((d, csv))
}

/// `d[key]` = the values as a NumPy array.
fn set_column<T: numpy::Element>(
    d: &Bound<'_, PyDict>,
    key: &str,
    values: impl Iterator<Item = T>,
) -> PyResult<()> {
    d.set_item(key, values.collect::<Vec<T>>().into_pyarray(d.py()))
}

/// The solver of `command`'s runs: a `[cutting]` scenario's delay stepping where the command
/// supports the cut (`run`, `ensemble`), refused with the section named elsewhere.
fn make_solver(sc: &Scenario, command: &str) -> PyResult<Box<dyn Solver>> {
    if sc.cutting.is_some() {
        if !vibrobar_scenario::CUTTING_COMMANDS.contains(&command) {
            return Err(PyValueError::new_err(vibrobar_scenario::cutting_refusal(
                command,
            )));
        }
        if let Some(s) = sc.cutting_solver().map_err(anyhow_input)? {
            return Ok(s);
        }
    }
    solver_by_name(&sc.run.solver, &sc.settings()).ok_or_else(|| {
        PyValueError::new_err(format!(
            "solver must be one of {}, got {:?}",
            SOLVER_NAMES.join(", "),
            sc.run.solver
        ))
    })
}

/// An array argument: 1-d, finite values accepted by `ok`, at most `max` of them.
fn values(
    name: &str,
    a: &PyReadonlyArray1<'_, f64>,
    ok: impl Fn(f64) -> bool,
    allowed: &str,
    max: usize,
) -> PyResult<Vec<f64>> {
    let v = a.as_array().to_vec();
    if v.is_empty() {
        return Err(PyValueError::new_err(format!(
            "{name} is empty (allowed: one or more values in {allowed})"
        )));
    }
    if v.len() > max {
        return Err(PyValueError::new_err(format!(
            "{name} has {} values, more than the limit of {max}",
            v.len()
        )));
    }
    if let Some((i, x)) = v
        .iter()
        .enumerate()
        .find(|(_, x)| !x.is_finite() || !ok(**x))
    {
        return Err(PyValueError::new_err(format!(
            "{name}[{i}] = {x} is outside the allowed range {allowed}"
        )));
    }
    Ok(v)
}

fn runner<'a>(
    ctl: &'a Ctl,
    progress: &'a (dyn Fn(usize, usize) + Sync),
    threads: Option<usize>,
) -> Runner<'a> {
    Runner::default()
        .with_progress(progress)
        .with_cancel(&ctl.cancel)
        .with_threads(threads)
}

fn check_threads(threads: Option<usize>) -> PyResult<()> {
    if let Some(n) = threads {
        limits::check_count("threads", n, 1, limits::MAX_THREADS, "").map_err(input_error)?;
    }
    Ok(())
}

/// Python warnings for runs whose ball went too far beyond the wall (rk4), as the CLI warns.
fn warn_penetration(
    py: Python<'_>,
    worst: Option<(f64, f64, f64, f64)>,
    solver: &str,
) -> PyResult<()> {
    if let Some((f, pen, ratio, gap_m)) = worst {
        let msg = format!(
            "the ball went {pen:.2e} m beyond the wall, {:.1} % of the gap (warning above {} %) at ratio {}, gap {} m: {solver} detects impacts only after a step; lower dt_s or use solver=\"exact\"",
            100.0 * f,
            100.0 * limits::RK4_PENETRATION_WARN_FRACTION,
            iocsv::fmt_coord(ratio),
            iocsv::fmt_coord(gap_m)
        );
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyRuntimeWarning>(),
            &std::ffi::CString::new(msg).unwrap_or_default(),
            1,
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// run

/// The impacts of a run as they happen.
#[derive(Default)]
struct ImpactLog {
    t_s: Vec<f64>,
    wall: Vec<i64>,
    dw_before: Vec<f64>,
    dw_after: Vec<f64>,
    loss_j: Vec<f64>,
    cap: usize,
    dropped: bool,
}

impl Observer for ImpactLog {
    fn event(&mut self, ev: &Event) {
        if let EventKind::Impact {
            wall,
            dw_m_s,
            energy_loss_j,
        } = ev.kind
        {
            if self.t_s.len() >= self.cap {
                self.dropped = true;
                return;
            }
            self.t_s.push(ev.t_s);
            self.wall.push(wall.sign() as i64);
            self.dw_before.push(dw_m_s);
            self.dw_after.push(ev.after.dw_m_s());
            self.loss_j.push(energy_loss_j);
        }
    }
}

struct Collect<'a>(&'a mut Sampler);

impl Observer for Collect<'_> {
    fn segment(&mut self, seg: &dyn Segment) {
        self.0.segment(seg);
    }
}

/// One run of the scenario (its gap, ratio, initial state, solver and settings), as
/// `vibrobar run`: the history every `sample_every` steps, the impacts, the statistics and the
/// energy books.
#[pyfunction]
#[pyo3(signature = (scenario, sample_every = 10))]
fn run<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    sample_every: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.for_command("run")?;
    if sample_every == 0 {
        return Err(PyValueError::new_err(
            "sample_every = 0 is outside the allowed range [1, ∞) steps",
        ));
    }
    sc.validate().map_err(anyhow_input)?;
    let settings = sc.settings();
    let interval_s = sample_every as f64 * settings.dt_s;
    limits::check_samples(
        "rows = duration_s / (sample_every · dt_s)",
        settings.duration_s,
        interval_s,
    )
    .map_err(input_error)?;
    let solver = make_solver(sc, "run")?;
    let sys = sc.damped_system().map_err(anyhow_input)?;
    let init = sc.initial_state();
    let (res, samples, audit, log) = detached(py, None, |_| {
        let mut sampler = Sampler::new(init.t_s, interval_s);
        let mut audit = EnergyAudit::new(&sys);
        let mut log = ImpactLog {
            cap: limits::MAX_SAMPLES as usize,
            ..Default::default()
        };
        let r = {
            let mut c = Collect(&mut sampler);
            let mut obs: [&mut dyn Observer; 3] = [&mut audit, &mut c, &mut log];
            run_case(
                &sys,
                &init,
                &settings,
                solver.as_ref(),
                &mut Fanout(&mut obs),
            )
        };
        let r = r.map_err(run_error)?;
        Ok((r, (sampler.samples, sampler.cuts), audit, log))
    })?;
    let (samples, cuts) = samples;
    let d = PyDict::new(py);
    let schema = iocsv::history_schema();
    let mut cols: Vec<Vec<f64>> = (0..7).map(|_| Vec::with_capacity(samples.len())).collect();
    for s in &samples {
        for (c, x) in cols.iter_mut().zip(iocsv::history_values(s)) {
            c.push(x);
        }
    }
    let hist = PyDict::new(py);
    for (c, v) in schema.columns.iter().zip(cols) {
        hist.set_item(c.name.as_ref(), v.into_pyarray(py))?;
    }
    if !cuts.is_empty() {
        // A cutting run: the columns `vibrobar run` adds (its schema's names).
        let cs = iocsv::cutting_history_schema();
        let names: Vec<&str> = cs.columns[schema.columns.len()..]
            .iter()
            .map(|c| c.name.as_ref())
            .collect();
        set_column(&hist, names[0], cuts.iter().map(|c| c.chip_thickness_m))?;
        set_column(&hist, names[1], cuts.iter().map(|c| i64::from(c.in_cut)))?;
        set_column(&hist, names[2], cuts.iter().map(|c| c.cutting_force_n))?;
    }
    d.set_item("history", hist)?;
    let imp = PyDict::new(py);
    imp.set_item("t_s", log.t_s.into_pyarray(py))?;
    imp.set_item("wall", log.wall.into_pyarray(py))?;
    imp.set_item("dw_before_m_s", log.dw_before.into_pyarray(py))?;
    imp.set_item("dw_after_m_s", log.dw_after.into_pyarray(py))?;
    imp.set_item("energy_loss_j", log.loss_j.into_pyarray(py))?;
    d.set_item("impact_table", imp)?;
    d.set_item("impact_table_truncated", log.dropped)?;
    d.set_item("rms_m", res.rms_m)?;
    d.set_item("impacts", res.impacts)?;
    d.set_item("impacts_in_window", res.impacts_in_window)?;
    d.set_item("impacts_per_cycle", res.impacts_per_cycle)?;
    d.set_item("max_penetration_m", res.summary.max_penetration_m.max(0.0))?;
    d.set_item("solver", solver.name())?;
    if let Some(e) = audit.balance() {
        let b = PyDict::new(py);
        b.set_item("work_input_j", e.work_input_j)?;
        b.set_item("viscous_loss_j", e.viscous_loss_j)?;
        b.set_item("impact_loss_j", e.impact_loss_j)?;
        b.set_item("friction_work_j", e.friction_work_j)?;
        if sc.cutting.is_some() {
            b.set_item("cutting_work_j", e.cutting_work_j)?;
        }
        b.set_item("delta_mechanical_j", e.delta_mechanical_j)?;
        b.set_item("residual_j", e.residual_j)?;
        d.set_item("energy", b)?;
    }
    // Under the hertz law the penetration is the contact's own compression, not an error (as
    // the CLI).
    let gap_m = sys
        .damper
        .filter(|d| d.contact.law == vibrobar_core::ContactLaw::Restitution)
        .map_or(f64::INFINITY, |d| d.gap_m);
    let pen = res.summary.max_penetration_m;
    if let Some(f) = limits::excessive_penetration(pen, gap_m) {
        let ratio = sys.omega_rad_s() / sys.omega1_rad_s();
        warn_penetration(py, Some((f, pen, ratio, gap_m)), solver.name())?;
    }
    Ok(d)
}

// ---------------------------------------------------------------------------------------------
// sweep and map

/// `vibrobar sweep`: the damped and the solid bar over `ratios` × `gaps_m` (gap-major rows).
#[pyfunction]
#[pyo3(signature = (scenario, ratios = None, gaps_m = None, progress = None, threads = None, freqs_hz = None))]
#[allow(clippy::too_many_arguments)]
fn sweep<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratios: Option<PyReadonlyArray1<'py, f64>>,
    gaps_m: Option<PyReadonlyArray1<'py, f64>>,
    progress: Option<&Bound<'py, PyAny>>,
    threads: Option<usize>,
    freqs_hz: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let sc = scenario.for_command("sweep")?;
    check_threads(threads)?;
    let gaps_m = match &gaps_m {
        Some(g) => values("gaps_m", g, |x| x > 0.0, "(0, ∞) m", limits::MAX_SWEEP_RATIOS)?,
        None if sc.sweep.gaps_m.is_empty() => {
            return Err(PyValueError::new_err(
                "sweep.gaps_m = [] in the scenario: no gap to sweep (allowed: one or more gaps > 0 m; or give gaps_m)",
            ))
        }
        None => sc.sweep.gaps_m.clone(),
    };
    let max = limits::MAX_SWEEP_RATIOS + 1;
    let (ratios, solid) = match (&ratios, &freqs_hz) {
        (Some(_), Some(_)) => return Err(both_frequency_axes()),
        (None, Some(f)) => ratios_at_hz(&sc.base().map_err(anyhow_input)?, f, max)?,
        (Some(r), None) => (
            values("ratios", r, |x| x > 0.0, "(0, ∞)", max)?,
            SolidRatios::default(),
        ),
        (None, None) => (
            vibrobar_scenario::sweep_ratios(&sc.sweep).map_err(anyhow_input)?,
            SolidRatios::default(),
        ),
    };
    let points = sc.sweep_points(&gaps_m, &ratios);
    sc.bars().map_err(anyhow_input)?;
    for p in &points {
        let mut s = sc.clone();
        s.damper.gap_m = p.gap_m;
        s.forcing.frequency = Frequency::Ratio(p.ratio);
        s.validate().map_err(anyhow_input)?;
    }
    let settings = sc.settings();
    let solver = make_solver(sc, "sweep")?;
    let base = sc.base().map_err(anyhow_input)?;
    let rows = detached(py, progress, |ctl| {
        let prog = |d, t| ctl.progress(d, t);
        batch_result(sweep_audited_at(
            &points,
            &solid,
            &base,
            &settings,
            solver.as_ref(),
            runner(ctl, &prog, threads),
            false,
        ))
    })?;
    let restitution = base.ball.contact.law == vibrobar_core::ContactLaw::Restitution;
    let worst = rows
        .iter()
        .filter(|_| restitution)
        .filter_map(|r| {
            let pen = r.damped.summary.max_penetration_m;
            limits::excessive_penetration(pen, r.point.gap_m)
                .map(|f| (f, pen, r.point.ratio, r.point.gap_m))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0));
    warn_penetration(py, worst, solver.name())?;
    let table: Vec<Vec<Value>> = rows
        .iter()
        .map(|r| iocsv::SweepCsvRow::from(r).values())
        .collect();
    columns(py, &iocsv::sweep_schema(), &table)
}

/// `ratios` and `freqs_hz` of `sweep` and `map` given together.
fn both_frequency_axes() -> PyErr {
    PyValueError::new_err(
        "ratios and freqs_hz given together (allowed: one of them: ratios Ω/ω₁ > 0, or freqs_hz in (0, 1e7] Hz)",
    )
}

/// `freqs_hz` of `sweep` and `map` (the CLI's `--freqs-hz`): both bars at the same absolute
/// frequencies; the damped bar's ratios and the solid bar's.
fn ratios_at_hz(
    base: &SweepBase,
    freqs_hz: &PyReadonlyArray1<'_, f64>,
    max: usize,
) -> PyResult<(Vec<f64>, SolidRatios)> {
    let f = values(
        "freqs_hz",
        freqs_hz,
        |x| x > 0.0 && x <= limits::MAX_FRF_FREQUENCY_HZ,
        "(0, 1e7] Hz",
        max,
    )?;
    SolidRatios::at_hz(base, &f, "freqs_hz").map_err(input_error)
}

/// The map spec of a scenario, as `vibrobar map` and the explore commands build it.
fn map_spec(sc: &Scenario) -> PyResult<MapSpec> {
    Ok(MapSpec {
        base: sc.base().map_err(anyhow_input)?,
        friction: sc.damper.friction,
        settings: sc.settings(),
        tolerances: Tolerances::default(),
    })
}

fn describe(p: &GridPoint) -> String {
    p.coords
        .iter()
        .map(|(a, v)| format!("{} = {}", a.as_str(), iocsv::fmt_coord(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `vibrobar map`: a design map over ratios × gaps (and optionally friction levels,
/// restitutions, mass ratios), in grid order.
#[pyfunction]
#[pyo3(signature = (scenario, ratios, gaps_m, friction_forces_n = None, restitutions = None, mass_ratios = None, progress = None, threads = None, freqs_hz = None))]
#[allow(clippy::too_many_arguments)]
fn design_map<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratios: Option<PyReadonlyArray1<'py, f64>>,
    gaps_m: PyReadonlyArray1<'py, f64>,
    friction_forces_n: Option<PyReadonlyArray1<'py, f64>>,
    restitutions: Option<PyReadonlyArray1<'py, f64>>,
    mass_ratios: Option<PyReadonlyArray1<'py, f64>>,
    progress: Option<&Bound<'py, PyAny>>,
    threads: Option<usize>,
    freqs_hz: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let sc = scenario.for_command("design_map")?;
    check_threads(threads)?;
    let max = vibrobar_core::analysis::sweep::MAX_GRID_POINTS;
    let spec = map_spec(sc)?;
    let (ratios, solid) = match (&ratios, &freqs_hz) {
        (Some(_), Some(_)) => return Err(both_frequency_axes()),
        (None, None) => {
            return Err(PyValueError::new_err(
                "map needs ratios or freqs_hz (one of them: ratios Ω/ω₁ > 0, or freqs_hz in (0, 1e7] Hz)",
            ))
        }
        (None, Some(f)) => ratios_at_hz(&spec.base, f, max)?,
        (Some(r), None) => (
            values("ratios", r, |x| x > 0.0, "(0, ∞)", max)?,
            SolidRatios::default(),
        ),
    };
    let mut axes = vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: ratios,
        },
        GridAxis {
            axis: Axis::GapM,
            values: values("gaps_m", &gaps_m, |x| x > 0.0, "(0, ∞) m", max)?,
        },
    ];
    let mut extra = Vec::new();
    type Check = fn(f64) -> bool;
    type OptAxis<'a, 'py> = (
        &'a str,
        &'a Option<PyReadonlyArray1<'py, f64>>,
        Axis,
        Check,
        &'a str,
    );
    let optional: [OptAxis<'_, 'py>; 3] = [
        (
            "friction_forces_n",
            &friction_forces_n,
            Axis::FrictionForceN,
            |x| x >= 0.0,
            "[0, ∞) N",
        ),
        (
            "restitutions",
            &restitutions,
            Axis::Restitution,
            |x| (0.0..=1.0).contains(&x),
            "[0, 1]",
        ),
        (
            "mass_ratios",
            &mass_ratios,
            Axis::MassRatio,
            |x| x > 0.0,
            "(0, ∞)",
        ),
    ];
    for (name, a, axis, ok, allowed) in optional {
        if let Some(a) = a {
            axes.push(GridAxis {
                axis,
                values: values(name, a, ok, allowed, max)?,
            });
            extra.push(axis);
        }
    }
    let grid = Grid::new(axes).map_err(|e| input_error(format!("grid: {e}")))?;
    let settings = spec.settings;
    let points = grid.points();
    for p in &points {
        spec.damped_system(p)
            .and_then(|s| {
                s.validate()?;
                s.validate_horizon(0.0, settings.duration_s)?;
                spec.base.init.validate(&s)
            })
            .map_err(|e| input_error(format!("{e} (at {})", describe(p))))?;
    }
    let solver = make_solver(sc, "map")?;
    let rows = detached(py, progress, |ctl| {
        let prog = |d, t| ctl.progress(d, t);
        batch_result(
            spec.batch(solver.as_ref())
                .on(runner(ctl, &prog, threads))
                .run(
                    &points,
                    |p| solid.of(spec.ratio(p)),
                    |p, solid| {
                        compute_point_from(&spec, solver.as_ref(), p, &spec.base.init, solid.rms_m)
                    },
                ),
        )
    })?;
    let table: Vec<Vec<Value>> = rows.iter().map(|r| iocsv::map_values(r, &extra)).collect();
    columns(py, &iocsv::map_schema(&extra), &table)
}

// ---------------------------------------------------------------------------------------------
// one point: regime, Poincaré, Lyapunov

/// The damped system at (ratio, gap_m), validated, with the scenario's map spec.
fn point_system(
    sc: &Scenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
) -> PyResult<(MapSpec, GridPoint, System)> {
    let ratio = match ratio {
        Some(r) => r,
        None => sc.frequency_ratio().map_err(anyhow_input)?,
    };
    let gap_m = gap_m.unwrap_or(sc.damper.gap_m);
    for (name, x, allowed) in [("ratio", ratio, "(0, ∞)"), ("gap_m", gap_m, "(0, ∞) m")] {
        if !(x.is_finite() && x > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} = {x} is outside the allowed range {allowed}"
            )));
        }
    }
    let spec = map_spec(sc)?;
    let p = GridPoint {
        index: 0,
        coords: vec![(Axis::FreqRatio, ratio), (Axis::GapM, gap_m)],
    };
    let sys = spec.damped_system(&p).map_err(input_error)?;
    sys.validate().map_err(input_error)?;
    spec.base.init.validate(&sys).map_err(input_error)?;
    Ok((spec, p, sys))
}

fn transient(sc: &Scenario, t: Option<f64>) -> PyResult<f64> {
    let st = sc.settings();
    let t = t.unwrap_or(st.duration_s * (1.0 - st.rms_fraction));
    if !(t.is_finite() && t >= 0.0 && t < st.duration_s) {
        return Err(PyValueError::new_err(format!(
            "transient_s = {t} is outside the allowed range [0, duration_s = {}) s",
            st.duration_s
        )));
    }
    Ok(t)
}

/// The steady-state regime at one point (solid and damped runs), as a map row.
#[pyfunction]
#[pyo3(signature = (scenario, ratio = None, gap_m = None))]
fn regime<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.for_command("regime")?;
    let (spec, p, _) = point_system(sc, ratio, gap_m)?;
    let solver = make_solver(sc, "regime")?;
    let row = detached(py, None, |_| {
        compute_point(&spec, solver.as_ref(), &p).map_err(run_error)
    })?;
    let d = PyDict::new(py);
    d.set_item("regime", row.regime.to_string())?;
    d.set_item("ratio", row.ratio)?;
    d.set_item("gap_m", row.gap_m)?;
    d.set_item("rms_solid_m", row.rms_solid_m)?;
    d.set_item("rms_damped_m", row.rms_damped_m)?;
    d.set_item("reduction_pct", row.reduction_pct)?;
    d.set_item("impacts_per_cycle", row.impacts_per_cycle)?;
    Ok(d)
}

/// Stroboscopic Poincaré section at forcing phase `phase_deg`, after `transient_s`.
#[pyfunction]
#[pyo3(signature = (scenario, ratio = None, gap_m = None, phase_deg = 0.0, transient_s = None))]
fn poincare<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    phase_deg: f64,
    transient_s: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.for_command("poincare")?;
    let (spec, _, sys) = point_system(sc, ratio, gap_m)?;
    if !phase_deg.is_finite() {
        return Err(PyValueError::new_err(format!(
            "phase_deg = {phase_deg} must be finite"
        )));
    }
    let t = transient(sc, transient_s)?;
    limits::check_samples(
        "Poincaré points = (duration_s − transient_s) / forcing period",
        spec.settings.duration_s - t,
        sys.forcing_period_s(),
    )
    .map_err(input_error)?;
    let solver = make_solver(sc, "poincare")?;
    let pts = detached(py, None, |_| {
        let mut strobe = Stroboscope::for_system(&sys, phase_deg.to_radians(), t);
        let init = spec.base.init;
        solver
            .run(
                &sys,
                &init,
                init.t_s + spec.settings.duration_s,
                &mut strobe,
            )
            .map_err(run_error)?;
        Ok(strobe.points)
    })?;
    let rows: Vec<Vec<Value>> = pts
        .iter()
        .map(|s| iocsv::poincare_values(s).map(Value::F).to_vec())
        .collect();
    Ok(columns(py, &iocsv::poincare_schema(), &rows)?.0)
}

/// Exact linear stability lobes of regenerative chatter (`vibrobar lobes`): the speeds
/// `rpm_start:rpm_stop:rpm_step` as the command line expands and checks them, the scenario's
/// `[cutting]` and structure, the rows of its CSV.
#[pyfunction]
#[pyo3(signature = (scenario, rpm_start, rpm_stop, rpm_step))]
fn lobes<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    rpm_start: f64,
    rpm_stop: f64,
    rpm_step: f64,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let rpms = vibrobar_scenario::spindle_speeds("rpm", rpm_start, rpm_stop, rpm_step)
        .map_err(anyhow_input)?;
    let spec = scenario.inner.lobe_spec().map_err(anyhow_input)?;
    let rows = detached(py, None, |_| {
        let mut l = vibrobar_core::analysis::lobes::Lobes::new(&spec).map_err(input_error)?;
        rpms.iter()
            .map(|&n| l.row(n).map_err(input_error))
            .collect::<PyResult<Vec<_>>>()
    })?;
    let rows: Vec<Vec<Value>> = rows.iter().map(iocsv::lobes_values).collect();
    columns(py, &iocsv::lobes_schema(), &rows)
}

/// Lobes straight from a measured FRF (``vibrobar lobes --frf``): the receptance interpolated
/// between the lines by a natural cubic spline, no fit; only the scenario's `[cutting]` is used.
/// Returns the rows of the command's CSV.
#[pyfunction]
#[pyo3(signature = (scenario, freqs_hz, frf_re, frf_im, kind, rpm_start, rpm_stop, rpm_step))]
#[allow(clippy::too_many_arguments)]
fn lobes_frf<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    freqs_hz: PyReadonlyArray1<'py, f64>,
    frf_re: PyReadonlyArray1<'py, f64>,
    frf_im: PyReadonlyArray1<'py, f64>,
    kind: &str,
    rpm_start: f64,
    rpm_stop: f64,
    rpm_step: f64,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::lobes_frf::FrfLobeTable;
    use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
    let kind = FrfKind::parse(kind).ok_or_else(|| {
        PyValueError::new_err(format!(
            "kind must be 'receptance', 'mobility' or 'accelerance', got {kind:?}"
        ))
    })?;
    let rpms = vibrobar_scenario::spindle_speeds("rpm", rpm_start, rpm_stop, rpm_step)
        .map_err(anyhow_input)?;
    let cut = scenario.inner.cutting.as_ref().ok_or_else(|| {
        PyValueError::new_err(
            "lobes from an FRF need a scenario with a [cutting] section (coefficient_n_m2 and the direction factors)",
        )
    })?;
    cut.validate().map_err(input_error)?;
    let k_o = cut.coefficient_n_m2 * cut.force_direction_factor * cut.chip_direction_factor;
    let (f, h, _) = frf_arrays("frf", &freqs_hz, &frf_re, &frf_im, None)?;
    let frf = MeasuredFrf::new(f, h, kind, None, true, String::new()).map_err(input_error)?;
    let rows = detached(py, None, |_| {
        let table = FrfLobeTable::new(&frf).map_err(input_error)?;
        rpms.iter()
            .map(|&n| {
                table
                    .boundary_at(n, k_o)
                    .map(|b| iocsv::lobes_frf_values(n, &b))
                    .map_err(input_error)
            })
            .collect::<PyResult<Vec<_>>>()
    })?;
    columns(py, &iocsv::lobes_frf_schema(), &rows)
}

/// The largest Lyapunov exponent at one point (two nearby trajectories, renormalised every
/// `periods` forcing periods).
#[pyfunction]
#[pyo3(signature = (scenario, ratio = None, gap_m = None, transient_s = None, periods = 5.0, d0 = 1e-9))]
fn lyapunov<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    transient_s: Option<f64>,
    periods: f64,
    d0: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.for_command("lyapunov")?;
    let (spec, _, sys) = point_system(sc, ratio, gap_m)?;
    let t = transient(sc, transient_s)?;
    for (name, x) in [("periods", periods), ("d0", d0)] {
        if !(x.is_finite() && x > 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} = {x} is outside the allowed range (0, ∞)"
            )));
        }
    }
    let interval = periods * sys.forcing_period_s();
    let duration = spec.settings.duration_s;
    let intervals = ((duration - t) / interval).floor() as usize;
    if intervals < 2 {
        return Err(PyValueError::new_err(format!(
            "duration_s = {duration} s leaves {intervals} intervals of {interval:.3e} s after the transient; at least 2 are needed (raise duration_s or lower periods)"
        )));
    }
    let mut p = LyapunovParams::periods(&sys, t, periods, intervals);
    p.d0 = d0;
    p.blocks = p.blocks.min(intervals);
    let solver = make_solver(sc, "lyapunov")?;
    let settings = spec.settings;
    let init = spec.base.init;
    let r = detached(py, None, |_| match &sys.bar {
        BarModel::Lumped(_) => max_lyapunov(&sys, &init, solver.as_ref(), &p).map_err(run_error),
        BarModel::Modal(model) => {
            let run = modal_run_by_name(solver.name(), &settings).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "no modal run for solver {} on a beam",
                    solver.name()
                ))
            })?;
            let init = ModalState::from_public(model, &init).map_err(input_error)?;
            let ms = ModalSystem::from_system(&sys).map_err(input_error)?;
            max_lyapunov_modal(&ms, &init, &*run, &p).map_err(run_error)
        }
    })?;
    lyapunov_dict(py, &r, intervals, interval, d0)
}

/// The dict of a largest-exponent estimate over `intervals` intervals of `interval` s.
fn lyapunov_dict<'py>(
    py: Python<'py>,
    r: &vibrobar_core::analysis::lyapunov::LyapunovResult,
    intervals: usize,
    interval: f64,
    d0: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("exponent_per_s", r.exponent_per_s)?;
    d.set_item("std_error_per_s", r.std_error_per_s)?;
    d.set_item("intervals", intervals)?;
    d.set_item("interval_s", interval)?;
    d.set_item("blocks", r.block_means_per_s.len())?;
    d.set_item("clamped", r.clamped)?;
    d.set_item("d0", d0)?;
    Ok(d)
}

/// Every Lyapunov exponent at one point by QR of the variational flow with saltation matrices
/// (lumped bar, exact solver, restitution law), over the run after the transient.
#[pyfunction]
#[pyo3(signature = (scenario, ratio = None, gap_m = None, transient_s = None, blocks = 10))]
fn lyapunov_spectrum<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    transient_s: Option<f64>,
    blocks: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.for_command("lyapunov_spectrum")?;
    let (spec, _, sys) = point_system(sc, ratio, gap_m)?;
    let t = transient(sc, transient_s)?;
    let solver = make_solver(sc, "lyapunov")?;
    if solver.name() != "exact" {
        return Err(PyValueError::new_err(format!(
            "lyapunov_spectrum needs solver = \"exact\" (the saltation matrices need the event times the exact solver resolves; got {:?})",
            solver.name()
        )));
    }
    let p = SpectrumParams {
        transient_s: t,
        duration_s: spec.settings.duration_s - t,
        blocks,
        scales: None,
    };
    let init = spec.base.init;
    let r = detached(py, None, |_| match &sys.bar {
        BarModel::Lumped(_) => core_spectrum(&sys, &init, solver.as_ref(), &p).map_err(run_error),
        // An N-mode bar: 2N + 2 exponents of the modal variational flow.
        BarModel::Modal(model) => {
            let init = ModalState::from_public(model, &init).map_err(input_error)?;
            let ms = ModalSystem::from_system(&sys).map_err(input_error)?;
            vibrobar_core::analysis::lyapunov_spectrum::lyapunov_spectrum_modal(&ms, &init, &p)
                .map_err(run_error)
        }
    })?;
    let d = PyDict::new(py);
    // −∞ (a direction removed by stick or wall contact) is None.
    d.set_item("exponents_per_s", r.exponents_per_s.clone())?;
    d.set_item("std_error_per_s", r.std_error_per_s.clone())?;
    d.set_item("collapsed", r.collapsed)?;
    d.set_item("sum_per_s", r.sum_per_s)?;
    d.set_item("impacts_per_s", r.impacts_per_s)?;
    d.set_item("duration_s", r.duration_s)?;
    d.set_item("blocks", blocks)?;
    d.set_item("chatter_limits", r.events.chatter_limits)?;
    d.set_item("grazing", r.events.grazing)?;
    // Hertz law: the part of the sum that is the law's memory of the approach speed.
    d.set_item("approach_memory_per_s", r.approach_memory_per_s)?;
    d.set_item("compliant_contacts", r.events.compliant_contacts)?;
    d.set_item(
        "volume_identity_per_s",
        vibrobar_core::analysis::lyapunov_spectrum::volume_identity_per_s(&sys, r.impacts_per_s)
            .map_err(run_error)?,
    )?;
    Ok(d)
}

// ---------------------------------------------------------------------------------------------
// periodic orbits and continuation (issue #11)

/// The starting orbit of `orbit` and `continuation`: `start` is "auto", "symmetric" (with
/// `branch`) or "settled" (with `settle_s`, default the transient).
fn start_orbit(
    sc: &Scenario,
    sys: &System,
    period: u32,
    start: &str,
    branch: Option<usize>,
    settle_s: Option<f64>,
) -> PyResult<vibrobar_core::analysis::orbit::PeriodicOrbit> {
    use vibrobar_core::analysis::orbit::*;
    check_period(period).map_err(input_error)?;
    let settle = transient(sc, settle_s)?;
    let settle = if settle > 0.0 {
        settle
    } else {
        sc.settings().duration_s
    };
    let init = map_spec(sc)?.base.init;
    let jac = ExactJacobian;
    let newton = NewtonSettings::default();
    let from = |st: Start| -> PyResult<PeriodicOrbit> {
        let (sec, x0) = starting_guess(sys, period, &st).map_err(input_error)?;
        find_orbit(&sec, &x0, &jac, &newton).map_err(run_error)
    };
    match start {
        "auto" => orbit_auto(sys, period, &init, settle, &jac)
            .map(|(o, _)| o)
            .map_err(run_error),
        "symmetric" => from(Start::Symmetric(branch.unwrap_or(0))),
        "settled" => from(Start::Settled {
            init,
            settle_s: settle,
        }),
        _ => Err(PyValueError::new_err(format!(
            "start must be \"auto\", \"symmetric\" or \"settled\", got {start:?}"
        ))),
    }
}

fn orbit_dict<'py>(
    py: Python<'py>,
    o: &vibrobar_core::analysis::orbit::PeriodicOrbit,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("rms_m", o.rms_m)?;
    d.set_item("impacts_per_period", o.impacts_per_period)?;
    d.set_item("period", o.section.periods)?;
    let mult: Vec<(f64, f64)> = o.multipliers.iter().map(|l| (l.re, l.im)).collect();
    d.set_item("multipliers", mult)?;
    d.set_item("max_abs_multiplier", o.max_abs_multiplier())?;
    d.set_item("stable", o.stable())?;
    d.set_item("event_sequence", &o.sequence)?;
    let s = &o.state;
    d.set_item(
        "state",
        [
            ("t_s", s.t_s),
            ("u_m", s.u_m),
            ("du_m_s", s.du_m_s),
            ("w_m", s.w_m()),
            ("dw_m_s", s.dw_m_s()),
        ]
        .into_py_dict(py)?,
    )?;
    d.set_item("confined", o.physicality.confined)?;
    d.set_item("max_penetration_m", o.physicality.max_penetration_m)?;
    d.set_item("residual", o.residual)?;
    Ok(d)
}

/// A periodic orbit of `period` forcing cycles at one point (Newton on the stroboscopic map).
#[pyfunction]
#[pyo3(signature = (scenario, ratio = None, gap_m = None, period = 1, start = "auto", branch = None, settle_s = None))]
#[allow(clippy::too_many_arguments)]
fn orbit<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    period: u32,
    start: &str,
    branch: Option<usize>,
    settle_s: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.for_command("orbit")?;
    let (_, _, sys) = point_system(sc, ratio, gap_m)?;
    if sys.lumped_bar().is_none() {
        let ms = ModalSystem::from_system(&sys).map_err(input_error)?;
        let o = detached(py, None, |_| {
            start_modal_orbit(sc, &ms, period, start, branch, settle_s)
        })?;
        return modal_orbit_dict(py, &o);
    }
    let start = start.to_string();
    let o = detached(py, None, |_| {
        start_orbit(sc, &sys, period, &start, branch, settle_s)
    })?;
    orbit_dict(py, &o)
}

/// The starting orbit of an N-mode bar: Newton from a settled run (`start` "auto" or
/// "settled"; the analytic symmetric orbit is the lumped bar's).
fn start_modal_orbit(
    sc: &Scenario,
    ms: &ModalSystem,
    period: u32,
    start: &str,
    branch: Option<usize>,
    settle_s: Option<f64>,
) -> PyResult<vibrobar_core::analysis::orbit::modal::ModalPeriodicOrbit> {
    vibrobar_core::analysis::orbit::check_period(period).map_err(input_error)?;
    if !matches!(start, "auto" | "settled") || branch.is_some() {
        return Err(PyValueError::new_err(format!(
            "start = {start:?}, branch = {branch:?}: on an N-mode bar an orbit starts from a settled run (start = \"auto\" or \"settled\", no branch); the analytic symmetric orbit is the lumped bar's"
        )));
    }
    let settle = transient(sc, settle_s)?;
    let settle = if settle > 0.0 {
        settle
    } else {
        sc.settings().duration_s
    };
    let init = ModalState::from_public(&ms.model, &map_spec(sc)?.base.init).map_err(input_error)?;
    vibrobar_core::analysis::orbit::modal::modal_orbit_settled(ms, period, &init, settle)
        .map_err(run_error)
}

fn modal_orbit_dict<'py>(
    py: Python<'py>,
    o: &vibrobar_core::analysis::orbit::modal::ModalPeriodicOrbit,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::structure::Point;
    let d = PyDict::new(py);
    let sys = &o.section.system;
    let n = sys.n_modes();
    d.set_item("rms_m", o.rms_m)?;
    d.set_item("impacts_per_period", o.impacts_per_period)?;
    d.set_item("period", o.section.periods)?;
    let mult: Vec<(f64, f64)> = o.multipliers.iter().map(|l| (l.re, l.im)).collect();
    d.set_item("multipliers", mult)?;
    d.set_item("max_abs_multiplier", o.max_abs_multiplier())?;
    d.set_item("stable", o.stable())?;
    d.set_item("event_sequence", &o.sequence)?;
    d.set_item("modes", n)?;
    let s = &o.state;
    let st = [
        ("t_s", s.t_s),
        ("u_m", s.u_at(&sys.model, Point::Response)),
        ("du_m_s", s.du_at(&sys.model, Point::Response)),
        ("w_m", s.w_m(&sys.model)),
        ("dw_m_s", s.dw_m_s(&sys.model)),
    ]
    .into_py_dict(py)?;
    st.set_item("q_m", s.q_m[..n].to_vec())?;
    st.set_item("dq_m_s", s.dq_m_s[..n].to_vec())?;
    d.set_item("state", st)?;
    d.set_item("confined", o.physicality.confined)?;
    d.set_item("max_penetration_m", o.physicality.max_penetration_m)?;
    d.set_item("residual", o.residual)?;
    Ok(d)
}

/// Continuation of the orbit at `param = from_` to `to` ("ratio", "gap_m", "friction_force_n",
/// "restitution"; SI): the continuation CSV's columns and its text.
#[pyfunction]
#[pyo3(signature = (scenario, param, from_, to, ratio = None, gap_m = None, period = 1, start = "auto", max_points = 2000, switch_branches = true))]
#[allow(clippy::too_many_arguments)]
fn continuation<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    param: &str,
    from_: f64,
    to: f64,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    period: u32,
    start: &str,
    max_points: usize,
    switch_branches: bool,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::orbit::continuation::*;
    use vibrobar_core::analysis::orbit::modal::{continue_modal_orbit, ModalFamily, ModalParam};
    let sc = scenario.for_command("continuation")?;
    let modal = sc.beam.is_some() || sc.modes.is_some();
    let axis = match param {
        "ratio" => Some(Axis::FreqRatio),
        "gap_m" => Some(Axis::GapM),
        "friction_force_n" => Some(Axis::FrictionForceN),
        "restitution" => Some(Axis::Restitution),
        "cavity_position_m" if sc.beam.is_some() && sc.modes.is_none() => None,
        _ => {
            return Err(PyValueError::new_err(format!(
                "param must be one of \"ratio\", \"gap_m\", \"friction_force_n\", \"restitution\", \"cavity_position_m\" (a [beam] only), got {param:?}"
            )))
        }
    };
    check_interval(axis.unwrap_or(Axis::GapM), from_, to).map_err(input_error)?;
    let (ratio, gap_m) = match axis {
        Some(Axis::FreqRatio) => (Some(from_), gap_m),
        Some(Axis::GapM) => (ratio, Some(from_)),
        _ => (ratio, gap_m),
    };
    let (_, _, mut sys) = point_system(sc, ratio, gap_m)?;
    let settings = ContinuationSettings {
        max_points,
        switch_branches,
        ..Default::default()
    };
    // One row per point: the CSV values and the dict's columns.
    let rows: Vec<(Vec<Value>, BranchColumns)> = if modal {
        let mp = axis.map_or(ModalParam::CavityPositionM, ModalParam::Axis);
        let mut fam = ModalFamily {
            base: ModalSystem::from_system(&sys).map_err(input_error)?,
            beam: sc.beam.clone().filter(|_| sc.modes.is_none()),
            param: mp,
        };
        fam.system_at(to).map_err(run_error)?;
        fam.base = fam.system_at(from_).map_err(run_error)?;
        if let (ModalParam::CavityPositionM, Some(b)) = (mp, fam.beam.as_mut()) {
            b.cavity_position_m = from_;
        }
        let b = detached(py, None, |_| {
            let o = start_modal_orbit(sc, &fam.base, period, start, None, None)?;
            continue_modal_orbit(&o, &fam, from_, to, &settings).map_err(run_error)
        })?;
        branch_rows(&b)
    } else {
        let axis = axis.ok_or_else(|| {
            PyValueError::new_err("param \"cavity_position_m\" needs a scenario with a [beam]")
        })?;
        axis.apply(&mut sys, from_).map_err(input_error)?;
        sys.validate().map_err(input_error)?;
        let b = detached(py, None, |_| {
            let o = start_orbit(sc, &sys, period, start, None, None)?;
            continue_orbit(
                &o,
                axis,
                from_,
                to,
                &vibrobar_core::analysis::orbit::ExactJacobian,
                &settings,
            )
            .map_err(run_error)
        })?;
        branch_rows(&b)
    };
    let schema = iocsv::continuation_schema();
    let mut csv = schema.header();
    csv.push('\n');
    for (v, _) in &rows {
        csv.push_str(&schema.format(v));
        csv.push('\n');
    }
    let d = PyDict::new(py);
    let pts = || rows.iter().map(|(_, c)| c);
    set_column(&d, "param", pts().map(|p| p.param))?;
    set_column(&d, "rms_m", pts().map(|p| p.rms_m))?;
    set_column(
        &d,
        "max_abs_multiplier",
        pts().map(|p| p.max_abs_multiplier),
    )?;
    set_column(&d, "stable", pts().map(|p| p.stable))?;
    set_column(
        &d,
        "impacts_per_period",
        pts().map(|p| p.impacts_per_period),
    )?;
    set_column(&d, "period", pts().map(|p| p.period))?;
    d.set_item("event", pts().map(|p| p.event).collect::<Vec<_>>())?;
    Ok((d, csv))
}

/// The dict columns of one continuation point (lumped or N-mode).
struct BranchColumns {
    param: f64,
    rms_m: f64,
    max_abs_multiplier: f64,
    stable: bool,
    impacts_per_period: u64,
    period: u64,
    event: &'static str,
}

/// The CSV values and the dict's columns of every point of a branch (either bar).
fn branch_rows<F: vibrobar_core::analysis::orbit::Flow>(
    b: &vibrobar_core::analysis::orbit::continuation::Branch<F>,
) -> Vec<(Vec<Value>, BranchColumns)> {
    b.points
        .iter()
        .map(|p| {
            let o = &p.orbit;
            let c = BranchColumns {
                param: p.param,
                rms_m: o.rms_m,
                max_abs_multiplier: o.max_abs_multiplier(),
                stable: o.stable(),
                impacts_per_period: o.impacts_per_period as u64,
                period: o.section.periods() as u64,
                event: p.event.map_or("", |e| e.as_str()),
            };
            (iocsv::continuation_values(p, 1.0), c)
        })
        .collect()
}

/// Two-parameter curve in (ratio, gap) of a `kind` point ("fold", "period-doubling", "torus",
/// "branch-point", "grazing") through the point (`ratio`, `gap_m`), within `ratios` × `gaps_m`
/// (SI): the `continue2` CSV's columns and its text.
#[pyfunction]
#[pyo3(signature = (scenario, kind, ratio, gap_m, ratios = (0.95, 1.05), gaps_m = (5e-6, 1e-3), period = 1, max_points = 400))]
#[allow(clippy::too_many_arguments)]
fn continuation2<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    kind: &str,
    ratio: f64,
    gap_m: f64,
    ratios: (f64, f64),
    gaps_m: (f64, f64),
    period: u32,
    max_points: usize,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::orbit::two_param::*;
    let sc = scenario.for_command("continuation2")?;
    let kind = CurveKind::parse(kind).map_err(PyValueError::new_err)?;
    let settings = Curve2Settings {
        ratios,
        gaps_m,
        max_points,
        ..Default::default()
    };
    check_settings(&settings).map_err(input_error)?;
    let (_, _, sys) = point_system(sc, Some(ratio), Some(gap_m))?;
    let c = detached(py, None, |_| {
        let sym = vibrobar_core::analysis::orbit::region::symmetric_orbit_at(
            &sys,
            &vibrobar_core::analysis::orbit::ExactJacobian,
        );
        let o = match (period, sym) {
            (1, Some(o)) => o,
            _ => start_orbit(sc, &sys, period, "auto", None, None)?,
        };
        continue_curve(&o, kind, &settings).map_err(run_error)
    })?;
    let schema = iocsv::curve2_schema();
    let mut csv = schema.header();
    csv.push('\n');
    for p in &c.points {
        csv.push_str(&schema.format(&iocsv::curve2_values(kind, p)));
        csv.push('\n');
    }
    let d = PyDict::new(py);
    let pts = || c.points.iter();
    set_column(&d, "ratio", pts().map(|p| p.ratio))?;
    set_column(&d, "gap_mm", pts().map(|p| p.gap_m * 1e3))?;
    d.set_item("kind", vec![kind.as_str(); c.points.len()])?;
    set_column(&d, "rms_m", pts().map(|p| p.orbit.rms_m))?;
    set_column(
        &d,
        "max_abs_multiplier",
        pts().map(|p| p.orbit.max_abs_multiplier()),
    )?;
    set_column(&d, "on_boundary", pts().map(on_boundary))?;
    set_column(&d, "test_function", pts().map(|p| p.test))?;
    set_column(&d, "residual", pts().map(|p| p.residual))?;
    set_column(
        &d,
        "impacts_per_period",
        pts().map(|p| p.orbit.impacts_per_period as u64),
    )?;
    let ev: Vec<&str> = c
        .points
        .iter()
        .map(|p| p.event.map_or("", |e| e.as_str()))
        .collect();
    d.set_item("event", ev)?;
    Ok((d, csv))
}

// ---------------------------------------------------------------------------------------------
// bifurcation and ensembles (chunked: their core functions take no cancel flag)

/// A bifurcation diagram: stroboscopic `u` against `param` ("ratio" or "gap_m", SI values).
#[pyfunction]
#[pyo3(signature = (scenario, param, values_, ratio = None, gap_m = None, phase_deg = 0.0, transient_s = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn bifurcation_diagram<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    param: &str,
    values_: PyReadonlyArray1<'py, f64>,
    ratio: Option<f64>,
    gap_m: Option<f64>,
    phase_deg: f64,
    transient_s: Option<f64>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
    let sc = scenario.for_command("bifurcation_diagram")?;
    let axis = match param {
        "ratio" => Axis::FreqRatio,
        "gap_m" => Axis::GapM,
        other => {
            return Err(PyValueError::new_err(format!(
                "param must be \"ratio\" or \"gap_m\", got {other:?}"
            )))
        }
    };
    let vals = values(
        "values",
        &values_,
        |x| x > 0.0,
        "(0, ∞)",
        limits::MAX_SWEEP_RATIOS * 100,
    )?;
    let (spec, _, sys) = point_system(sc, ratio, gap_m)?;
    for &v in &vals {
        let mut s = sys;
        axis.apply(&mut s, v).map_err(input_error)?;
        s.validate().map_err(input_error)?;
        spec.base.init.validate(&s).map_err(input_error)?;
    }
    if !phase_deg.is_finite() {
        return Err(PyValueError::new_err(format!(
            "phase_deg = {phase_deg} must be finite"
        )));
    }
    let bs = BifurcationSpec {
        system: sys,
        axis,
        init: spec.base.init,
        duration_s: spec.settings.duration_s,
        transient_s: transient(sc, transient_s)?,
        phase_rad: phase_deg.to_radians(),
        impact_wall: None,
    };
    let solver = make_solver(sc, "bifurcation")?;
    let b = detached(py, progress, |ctl| {
        let mut all = vibrobar_core::analysis::poincare::Bifurcation::default();
        let n = vals.len();
        for (k, chunk) in vals.chunks(chunk_len()).enumerate() {
            if ctl.cancelled() {
                return Err(PyKeyboardInterrupt::new_err("cancelled"));
            }
            let off = k * chunk_len();
            let prog = |d: usize, _| ctl.progress(off + d, n);
            let part = bifurcation(&bs, chunk, solver.as_ref(), &prog).map_err(batch_error)?;
            all.points.extend(part.points);
            all.impacts.extend(part.impacts);
        }
        Ok(all)
    })?;
    let pts = PyDict::new(py);
    set_column(&pts, param, b.points.iter().map(|p| p.param))?;
    set_column(&pts, "t_s", b.points.iter().map(|p| p.t_s))?;
    set_column(&pts, "u_m", b.points.iter().map(|p| p.u_m))?;
    set_column(&pts, "du_m_s", b.points.iter().map(|p| p.du_m_s))?;
    let imp = PyDict::new(py);
    set_column(&imp, param, b.impacts.iter().map(|p| p.param))?;
    set_column(&imp, "t_s", b.impacts.iter().map(|p| p.t_s))?;
    set_column(&imp, "wall", b.impacts.iter().map(|p| p.wall.sign() as i64))?;
    set_column(&imp, "dw_m_s", b.impacts.iter().map(|p| p.dw_m_s))?;
    Ok((pts, imp))
}

/// Ensembles of random initial states at each (ratio, gap) point: RMS statistics and regimes.
#[pyfunction]
#[pyo3(signature = (scenario, ratios, gaps_m, members = 16, seed = 1, u_m = 5e-5, du_m_s = 0.2, dw_m_s = 0.2, progress = None))]
#[allow(clippy::too_many_arguments)]
fn ensemble<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    ratios: PyReadonlyArray1<'py, f64>,
    gaps_m: PyReadonlyArray1<'py, f64>,
    members: usize,
    seed: u64,
    u_m: f64,
    du_m_s: f64,
    dw_m_s: f64,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let sc = scenario.for_command("ensemble")?;
    let max = vibrobar_core::analysis::sweep::MAX_GRID_POINTS;
    let grid = Grid::new(vec![
        GridAxis {
            axis: Axis::FreqRatio,
            values: values("ratios", &ratios, |x| x > 0.0, "(0, ∞)", max)?,
        },
        GridAxis {
            axis: Axis::GapM,
            values: values("gaps_m", &gaps_m, |x| x > 0.0, "(0, ∞) m", max)?,
        },
    ])
    .map_err(input_error)?;
    if members == 0 {
        return Err(PyValueError::new_err(
            "members = 0 is outside the allowed range [1, ∞)",
        ));
    }
    for (name, x, unit) in [
        ("u_m", u_m, "m"),
        ("du_m_s", du_m_s, "m/s"),
        ("dw_m_s", dw_m_s, "m/s"),
    ] {
        if !(x.is_finite() && x >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} = {x} is outside the allowed range [0, ∞) {unit}"
            )));
        }
    }
    let spec = map_spec(sc)?;
    let points = grid.points();
    for p in &points {
        spec.damped_system(p)
            .and_then(|s| s.validate())
            .map_err(|e| input_error(format!("{e} (at {})", describe(p))))?;
    }
    let params = EnsembleParams {
        seed,
        members,
        ranges: IcRanges {
            u_m: (-u_m, u_m),
            du_m_s: (-du_m_s, du_m_s),
            w_over_half_gap: (-1.0, 1.0),
            dw_m_s: (-dw_m_s, dw_m_s),
        },
    };
    params.validate().map_err(input_error)?;
    let solver = make_solver(sc, "ensemble")?;
    let stats = detached(py, progress, |ctl| {
        let per = chunk_len().div_ceil(members).max(1);
        let n = points.len() * members;
        let mut all = Vec::with_capacity(points.len());
        for (k, chunk) in points.chunks(per).enumerate() {
            if ctl.cancelled() {
                return Err(PyKeyboardInterrupt::new_err("cancelled"));
            }
            let off = k * per * members;
            let prog = |d: usize, _| ctl.progress(off + d, n);
            all.extend(
                run_ensemble(&spec, solver.as_ref(), chunk, &params, &prog).map_err(batch_error)?,
            );
        }
        Ok(all)
    })?;
    let rows: Vec<Vec<Value>> = stats
        .iter()
        .map(|s| {
            iocsv::EnsembleCsvRow {
                ratio: s.point.get(Axis::FreqRatio).unwrap_or(f64::NAN),
                gap_mm: s.point.get(Axis::GapM).unwrap_or(f64::NAN) * 1e3,
                members: s.members as u64,
                rms_m: [s.mean_rms_m, s.std_rms_m, s.min_rms_m, s.max_rms_m],
                regimes: iocsv::regime_counts(&s.regimes),
            }
            .values()
        })
        .collect();
    columns(py, &iocsv::ensemble_schema(), &rows)
}

/// Width–amplitude diagram of a `[cutting]` scenario at one spindle speed: for each
/// width, from the small and the large disturbance of `[time_domain]`, for the solid and the
/// damped bar, the settled vibration; the columns of `vibrobar width-diagram`.
#[pyfunction]
#[pyo3(signature = (scenario, spindle_rpm, widths_m, progress = None))]
fn width_diagram<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    spindle_rpm: f64,
    widths_m: PyReadonlyArray1<'py, f64>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::time_domain as td;
    let sc = scenario.for_command("width_diagram")?;
    let widths = values("widths_m", &widths_m, |x| x > 0.0, "(0, ∞) m", 100_000)?;
    vibrobar_core::limits::check(
        "spindle_rpm",
        spindle_rpm,
        vibrobar_core::limits::SPINDLE_RPM_MIN,
        vibrobar_core::limits::SPINDLE_RPM_MAX,
        "revolutions per minute",
    )
    .map_err(input_error)?;
    let p = sc.cut_problem().map_err(anyhow_input)?;
    let rows = detached(py, progress, |ctl| {
        let prog = |d: usize, n: usize| ctl.progress(d, n);
        let runner = vibrobar_core::analysis::Runner::default().with_progress(&prog);
        td::width_diagram(&p, spindle_rpm, &widths, &runner).map_err(batch_error)
    })?;
    let rows: Vec<Vec<Value>> = rows
        .iter()
        .map(|r| iocsv::width_diagram_values(r, spindle_rpm))
        .collect();
    columns(py, &iocsv::width_diagram_schema(), &rows)
}

/// Time-domain lobes of a `[cutting]` scenario: per spindle speed the largest
/// acceptable width of the solid and the damped bar from the small and the large disturbance;
/// the columns of `vibrobar lobes --time-domain`.
#[pyfunction]
#[pyo3(signature = (scenario, spindle_rpm, progress = None))]
fn time_domain_lobes<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    spindle_rpm: PyReadonlyArray1<'py, f64>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::time_domain as td;
    let sc = scenario.for_command("time_domain_lobes")?;
    let rpms = values(
        "spindle_rpm",
        &spindle_rpm,
        |x| {
            (vibrobar_core::limits::SPINDLE_RPM_MIN..=vibrobar_core::limits::SPINDLE_RPM_MAX)
                .contains(&x)
        },
        "[1, 200000] rpm",
        100_000,
    )?;
    let p = sc.cut_problem().map_err(anyhow_input)?;
    let rows = detached(py, progress, |ctl| {
        let prog = |d: usize, n: usize| ctl.progress(d, n);
        let runner = vibrobar_core::analysis::Runner::default().with_progress(&prog);
        td::td_lobes(&p, &rpms, &runner).map_err(batch_error)
    })?;
    let rows: Vec<Vec<Value>> = rows.iter().map(iocsv::td_lobes_values).collect();
    columns(py, &iocsv::td_lobes_schema(), &rows)
}

/// Design by time-domain lobes of a `[cutting]` scenario: each gap × ball mass
/// (`ball_masses_kg`) or gap × cavity position from the clamp (`positions_m`, a `[beam]`)
/// scored by its worst-case acceptable width over the speeds from the large disturbance, beside
/// the solid bar's (searched once per speed); the columns of `vibrobar lobe-design`, rows in its
/// order (gap outer).
#[pyfunction]
#[pyo3(signature = (scenario, spindle_rpm, gaps_m, ball_masses_kg = None, positions_m = None, progress = None))]
fn lobe_design<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    spindle_rpm: PyReadonlyArray1<'py, f64>,
    gaps_m: PyReadonlyArray1<'py, f64>,
    ball_masses_kg: Option<PyReadonlyArray1<'py, f64>>,
    positions_m: Option<PyReadonlyArray1<'py, f64>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::lobe_design as ld;
    let sc = scenario.for_command("lobe_design")?;
    let rpms = values(
        "spindle_rpm",
        &spindle_rpm,
        |x| {
            (vibrobar_core::limits::SPINDLE_RPM_MIN..=vibrobar_core::limits::SPINDLE_RPM_MAX)
                .contains(&x)
        },
        "[1, 200000] rpm",
        100_000,
    )?;
    let gaps = values("gaps_m", &gaps_m, |x| x > 0.0, "(0, ∞) m", 100_000)?;
    let (axis, second) = match (&ball_masses_kg, &positions_m) {
        (Some(m), None) => (
            ld::DesignAxis::BallMass,
            values("ball_masses_kg", m, |x| x > 0.0, "(0, ∞) kg", 100_000)?,
        ),
        (None, Some(x)) => (
            ld::DesignAxis::Position,
            values("positions_m", x, |x| x >= 0.0, "[0, L] m", 100_000)?,
        ),
        _ => {
            return Err(PyValueError::new_err(
                "give exactly one of ball_masses_kg (lumped bar) and positions_m (beam)",
            ))
        }
    };
    let spec = ld::LobeDesignSpec {
        base: sc.cut_problem().map_err(anyhow_input)?,
        beam: sc.beam.clone(),
        axis,
    };
    let grid = ld::DesignGrid::new(axis, gaps, second).map_err(input_error)?;
    let (_, rows) = detached(py, progress, |ctl| {
        let prog = |d: usize, n: usize| ctl.progress(d, n);
        let runner = vibrobar_core::analysis::Runner::default().with_progress(&prog);
        ld::lobe_design(&spec, &grid, &rpms, &runner).map_err(batch_error)
    })?;
    let rows: Vec<Vec<Value>> = rows.iter().map(iocsv::lobe_design_values).collect();
    columns(py, &iocsv::lobe_design_schema(axis), &rows)
}

// ---------------------------------------------------------------------------------------------
// measured FRFs: universal files (dataset 58/58b with 164) and plain columns

/// Read a measured FRF (`vibrobar lobes --frf` reads it the same way): a universal file or plain
/// columns, converted to SI, with the corrections asked for and the passivity check of a
/// driving point. Returns a dict: `freqs_hz`, `values` (complex, SI units of `kind`), `kind`,
/// `coherence` (or None), `driving_point`, `units_note`, `notes`, `format`.
#[pyfunction]
#[pyo3(signature = (path, units = None, frf_type = None, columns = None, record = None, conjugate = false, negate = false, accelerometer_mass_kg = None, cross = false))]
#[allow(clippy::too_many_arguments)]
fn read_frf<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    units: Option<String>,
    frf_type: Option<String>,
    columns: Option<String>,
    record: Option<usize>,
    conjugate: bool,
    negate: bool,
    accelerometer_mass_kg: Option<f64>,
    cross: bool,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::structure::frf_data::FrfKind;
    use vibrobar_io::frf::{ColumnLayout, FrfReadOptions};
    let kind = match &frf_type {
        None => None,
        Some(t) => Some(FrfKind::parse(t).ok_or_else(|| {
            PyValueError::new_err(format!(
                "frf_type must be 'receptance', 'mobility' or 'accelerance', got {t:?}"
            ))
        })?),
    };
    let columns = match &columns {
        None => ColumnLayout::default(),
        Some(c) => ColumnLayout::parse(c).ok_or_else(|| {
            PyValueError::new_err(format!(
                "columns must be 're-im', 'mag-deg' or 'mag-rad', got {c:?}"
            ))
        })?,
    };
    let opts = FrfReadOptions {
        units,
        kind,
        columns,
        record,
        conjugate,
        negate,
        accelerometer_mass_kg,
        cross,
    };
    let read = vibrobar_io::frf::read_frf(&path, &opts).map_err(input_error)?;
    let f = read.frf;
    let d = PyDict::new(py);
    d.set_item("freqs_hz", f.freqs_hz.into_pyarray(py))?;
    d.set_item("values", f.values.into_pyarray(py))?;
    d.set_item("kind", f.kind.name())?;
    match f.coherence {
        Some(c) => d.set_item("coherence", c.into_pyarray(py))?,
        None => d.set_item("coherence", py.None())?,
    }
    d.set_item("driving_point", f.driving_point)?;
    d.set_item("units_note", f.units_note)?;
    d.set_item("notes", read.notes)?;
    d.set_item("format", read.format)?;
    Ok(d)
}

/// Write a measured FRF as a universal file: dataset 164 (SI), the FRF as dataset 58b
/// (`binary`, little endian, doubles: values read back bit for bit) or ASCII 58 (12
/// significant digits), and its coherence if given. The values are SI units of `kind`.
#[pyfunction]
#[pyo3(signature = (path, freqs_hz, values, kind = "receptance", coherence = None, binary = true, driving_point = true, description = "vibrobar FRF"))]
#[allow(clippy::too_many_arguments)]
fn write_uff58(
    path: std::path::PathBuf,
    freqs_hz: PyReadonlyArray1<'_, f64>,
    values: PyReadonlyArray1<'_, numpy::Complex64>,
    kind: &str,
    coherence: Option<PyReadonlyArray1<'_, f64>>,
    binary: bool,
    driving_point: bool,
    description: &str,
) -> PyResult<()> {
    use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
    let k = FrfKind::parse(kind).ok_or_else(|| {
        PyValueError::new_err(format!(
            "kind must be 'receptance', 'mobility' or 'accelerance', got {kind:?}"
        ))
    })?;
    let frf = MeasuredFrf::new(
        freqs_hz.as_slice()?.to_vec(),
        values.as_slice()?.to_vec(),
        k,
        match &coherence {
            Some(c) => Some(c.as_slice()?.to_vec()),
            None => None,
        },
        driving_point,
        String::new(),
    )
    .map_err(input_error)?;
    let header = vibrobar_io::frf::Uff58Header {
        description: description.chars().take(80).collect(),
        rsp_node: 1,
        rsp_dir: 3,
        ref_node: if driving_point { 1 } else { 2 },
        ref_dir: 3,
    };
    vibrobar_io::frf::write_frf_uff(&path, &frf, &header, binary).map_err(input_error)
}
// end of measured FRFs
// frf: frequency response functions of every model (`vibrobar frf`)

/// One curve's name as the CSV prefixes it (hyphens accepted for the command line's spelling).
fn frf_curve_name(name: &str) -> PyResult<&'static str> {
    match name.replace('-', "_").as_str() {
        "solid" => Ok("solid"),
        "ball_free" => Ok("ball_free"),
        "ball_stuck" => Ok("ball_stuck"),
        "stepped_sine" => Ok("stepped_sine"),
        "tap" => Ok("tap"),
        _ => Err(PyValueError::new_err(format!(
            "curves: {name:?} is not a curve (allowed: solid, ball_free, ball_stuck, stepped_sine, tap)"
        ))),
    }
}

fn frf_point(field: &str, name: &str) -> PyResult<vibrobar_core::structure::Point> {
    use vibrobar_core::structure::Point;
    match name {
        "force" => Ok(Point::Force),
        "cavity" => Ok(Point::Cavity),
        "response" => Ok(Point::Response),
        _ => Err(PyValueError::new_err(format!(
            "{field} = {name:?} is not a point (allowed: force, cavity, response)"
        ))),
    }
}

/// Frequency response functions of the scenario's bar (`vibrobar frf`): the linear curves
/// (`solid`, `ball_free`, `ball_stuck`) between any two points, the stepped sine of the
/// nonlinear damped bar and the simulated tap test, at the lines `band_hz = (start, stop, step)`
/// or `frequencies_hz`; the columns of the command's CSV.
#[pyfunction]
#[pyo3(signature = (scenario, band_hz = None, frequencies_hz = None, curves = None, from_point = "force", to_point = "response", force_n = None, settle_s = None, measure_periods = 50, tap_force_n = 100.0, tap_duration_s = 1e-4, taps = 5, sample_rate_hz = None, record_s = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn frf<'py>(
    py: Python<'py>,
    scenario: &PyScenario,
    band_hz: Option<(f64, f64, f64)>,
    frequencies_hz: Option<PyReadonlyArray1<'py, f64>>,
    curves: Option<Vec<String>>,
    from_point: &str,
    to_point: &str,
    force_n: Option<f64>,
    settle_s: Option<f64>,
    measure_periods: u32,
    tap_force_n: f64,
    tap_duration_s: f64,
    taps: usize,
    sample_rate_hz: Option<f64>,
    record_s: Option<f64>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    use vibrobar_core::analysis::frf::{
        check_lines_hz, frequency_lines_hz, linear_frf, stepped_sine, tap_test, FrfCurve,
        ResponsePoint, SteppedSine, TapTest,
    };
    use vibrobar_core::structure::{Point, Structure};
    let sc = scenario.for_command("frf")?;
    let lines = match (band_hz, &frequencies_hz) {
        (Some((a, b, c)), None) => frequency_lines_hz("band_hz", a, b, c).map_err(input_error)?,
        (None, Some(f)) => {
            let v = f.as_array().to_vec();
            check_lines_hz("frequencies_hz", &v).map_err(input_error)?;
            v
        }
        _ => {
            return Err(PyValueError::new_err(
                "give the frequency lines as band_hz = (start, stop, step) or as frequencies_hz, one of the two",
            ))
        }
    };
    let names: Vec<String> =
        curves.unwrap_or_else(|| vec!["solid".into(), "ball_free".into(), "ball_stuck".into()]);
    let mut asked: Vec<&'static str> = Vec::new();
    for n in &names {
        let c = frf_curve_name(n)?;
        if !asked.contains(&c) {
            asked.push(c);
        }
    }
    if asked.is_empty() {
        return Err(PyValueError::new_err(
            "curves is empty (allowed: one or more of solid, ball_free, ball_stuck, stepped_sine, tap)",
        ));
    }
    let (from, to) = (
        frf_point("from_point", from_point)?,
        frf_point("to_point", to_point)?,
    );
    let simulated = asked.iter().any(|c| matches!(*c, "stepped_sine" | "tap"));
    if simulated && from != Point::Force {
        return Err(PyValueError::new_err(format!(
            "from_point = {from_point:?}: the stepped sine and the tap test force the force point (allowed: \"force\")"
        )));
    }
    let response = match to {
        Point::Response => ResponsePoint::Response,
        Point::Cavity => ResponsePoint::Cavity,
        Point::Force if simulated => {
            return Err(PyValueError::new_err(
                "to_point = \"force\": the stepped sine and the tap test read the response point or the cavity (allowed: \"response\", \"cavity\")",
            ))
        }
        Point::Force => ResponsePoint::Response,
    };
    let (damped_bar, solid_bar) = sc.bars().map_err(anyhow_input)?;
    let modal = |b: BarModel| -> PyResult<vibrobar_core::structure::ModalModel> {
        match b {
            BarModel::Lumped(bar) => Structure::Lumped(bar).modal_model().map_err(input_error),
            BarModel::Modal(m) => Ok(m),
        }
    };
    let (damped, solid) = (modal(damped_bar)?, modal(solid_bar)?);
    let md = sc.damper.ball_mass_kg;
    let mut sys = None;
    let mut solver = None;
    if simulated {
        sc.validate().map_err(anyhow_input)?;
        sys = Some(sc.damped_system().map_err(anyhow_input)?);
        // The bar's own solver: a [cutting] section is not applied (the FRF is out of the cut).
        solver = Some(
            solver_by_name(&sc.run.solver, &sc.settings()).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "solver must be one of {}, got {:?}",
                    SOLVER_NAMES.join(", "),
                    sc.run.solver
                ))
            })?,
        );
    }
    let ss_spec = SteppedSine {
        force_amplitude_n: force_n.unwrap_or(sc.forcing.amplitude_n),
        settle_s,
        measure_periods,
        response,
    };
    let tap_spec = TapTest {
        peak_force_n: tap_force_n,
        pulse_duration_s: tap_duration_s,
        taps,
        sample_rate_hz,
        record_s,
        response,
    };
    // Every setting checked before any run.
    if let Some(sys) = &sys {
        if asked.contains(&"stepped_sine") {
            ss_spec.validate(sys).map_err(input_error)?;
        }
        if asked.contains(&"tap") {
            tap_spec.validate(sys, &lines).map_err(input_error)?;
        }
    }
    let init = sc.initial;
    let out = detached(py, progress, |ctl| {
        let mut out = Vec::new();
        for c in &asked {
            let curve = match *c {
                "solid" => FrfCurve::linear(
                    "solid",
                    linear_frf(&solid, None, from, to, &lines).map_err(input_error)?,
                ),
                "ball_free" => FrfCurve::linear(
                    "ball_free",
                    linear_frf(&damped, None, from, to, &lines).map_err(input_error)?,
                ),
                "ball_stuck" => FrfCurve::linear(
                    "ball_stuck",
                    linear_frf(&damped, Some(md), from, to, &lines).map_err(input_error)?,
                ),
                "stepped_sine" => {
                    let prog = |d, t| ctl.progress(d, t);
                    let rows = batch_result(stepped_sine(
                        sys.as_ref().expect("simulated"),
                        &init,
                        &ss_spec,
                        &lines,
                        solver.as_deref().expect("simulated"),
                        runner(ctl, &prog, None),
                    ))?;
                    FrfCurve::stepped_sine(&rows)
                }
                _ => {
                    let prog = |d, t| ctl.progress(d, t);
                    let (rows, _) = batch_result(tap_test(
                        sys.as_ref().expect("simulated"),
                        &tap_spec,
                        &lines,
                        runner(ctl, &prog, None),
                    ))?;
                    FrfCurve::tap(&rows)
                }
            };
            out.push(curve);
        }
        Ok(out)
    })?;
    let table = vibrobar_io::frf_csv::frf_rows(&lines, &out);
    columns(py, &vibrobar_io::frf_csv::frf_schema(&out), &table)
}

/// Names of the solvers (`solver=` of a scenario).
#[pyfunction]
fn solver_names() -> Vec<&'static str> {
    SOLVER_NAMES.to_vec()
}

/// A test hook: a job that panics on the worker thread (the panic must come out as an
/// exception), and a job that runs `seconds` of busy work with the GIL released, cancellable
/// (the GIL and Ctrl-C tests).
#[pyfunction]
#[pyo3(signature = (seconds, panic = false))]
fn _busy(py: Python<'_>, seconds: f64, panic: bool) -> PyResult<f64> {
    detached(py, None, |ctl| {
        if panic {
            panic!("test panic");
        }
        let t0 = std::time::Instant::now();
        let mut x = 0.0f64;
        while t0.elapsed().as_secs_f64() < seconds {
            if ctl.cancelled() {
                return Err(PyKeyboardInterrupt::new_err("cancelled"));
            }
            for i in 0..10_000 {
                x += (i as f64).sqrt();
            }
        }
        Ok(x)
    })
}

// ---------------------------------------------------------------------------------------------
// the modal fit of a measured FRF

/// One FRF's lines: frequencies (Hz), values, optional weights.
type FrfArrays = (Vec<f64>, Vec<num_complex::Complex64>, Option<Vec<f64>>);

/// One FRF's lines from Python: frequencies (Hz), real and imaginary parts, optional weights.
fn frf_arrays(
    name: &str,
    freqs_hz: &PyReadonlyArray1<'_, f64>,
    re: &PyReadonlyArray1<'_, f64>,
    im: &PyReadonlyArray1<'_, f64>,
    weights: Option<&PyReadonlyArray1<'_, f64>>,
) -> PyResult<FrfArrays> {
    use vibrobar_core::structure::fit::MAX_FIT_LINES;
    let f = values(
        "freqs_hz",
        freqs_hz,
        |x| x > 0.0,
        "(0, ∞) Hz",
        MAX_FIT_LINES,
    )?;
    let re = re.as_array().to_vec();
    let im = im.as_array().to_vec();
    if re.len() != f.len() || im.len() != f.len() {
        return Err(PyValueError::new_err(format!(
            "{name} has {} values for {} frequencies (allowed: one value per frequency)",
            re.len(),
            f.len()
        )));
    }
    let h = re
        .iter()
        .zip(&im)
        .map(|(a, b)| num_complex::Complex64::new(*a, *b))
        .collect();
    let w = match weights {
        Some(w) => Some(values(
            "weights",
            w,
            |x| (0.0..=1.0).contains(&x),
            "[0, 1]",
            MAX_FIT_LINES,
        )?),
        None => None,
    };
    Ok((f, h, w))
}

/// Modes from a measured FRF (``vibrobar fit-modes``): LSCF poles, LSFD residues and their
/// refinement. Returns the modes, the quality figures and the stabilisation chart.
#[pyfunction]
#[pyo3(signature = (freqs_hz, frf_re, frf_im, form, cross_re = None, cross_im = None, weights = None, band_hz = None, max_order = 40, min_stable_orders = 4, poles_hz = None, upper_residual = true, lower_residual = false, refine = true))]
#[allow(clippy::too_many_arguments)]
fn fit_modes<'py>(
    py: Python<'py>,
    freqs_hz: PyReadonlyArray1<'py, f64>,
    frf_re: PyReadonlyArray1<'py, f64>,
    frf_im: PyReadonlyArray1<'py, f64>,
    form: &str,
    cross_re: Option<PyReadonlyArray1<'py, f64>>,
    cross_im: Option<PyReadonlyArray1<'py, f64>>,
    weights: Option<PyReadonlyArray1<'py, f64>>,
    band_hz: Option<(f64, f64)>,
    max_order: usize,
    min_stable_orders: usize,
    poles_hz: Option<Vec<f64>>,
    upper_residual: bool,
    lower_residual: bool,
    refine: bool,
) -> PyResult<Bound<'py, PyDict>> {
    use vibrobar_core::structure::fit::{self, FitSettings, FrfKind, FrfLines};
    let form = match form {
        "receptance" => FrfKind::Receptance,
        "mobility" => FrfKind::Mobility,
        "accelerance" => FrfKind::Accelerance,
        other => {
            return Err(PyValueError::new_err(format!(
                "form = {other:?} is not one of \"receptance\", \"mobility\", \"accelerance\""
            )))
        }
    };
    let (f, h, w) = frf_arrays("frf", &freqs_hz, &frf_re, &frf_im, weights.as_ref())?;
    let cross = match (&cross_re, &cross_im) {
        (Some(a), Some(b)) => Some(frf_arrays("cross", &freqs_hz, a, b, None)?.1),
        (None, None) => None,
        _ => {
            return Err(PyValueError::new_err(
                "cross needs both its real and imaginary parts (or neither)",
            ))
        }
    };
    if min_stable_orders == 0 {
        return Err(PyValueError::new_err(
            "min_stable_orders = 0 is outside the allowed range [1, max_order/2]",
        ));
    }
    let settings = FitSettings {
        band_hz,
        max_order,
        min_stable_orders,
        poles_hz,
        upper_residual,
        lower_residual,
        refine,
        ..FitSettings::default()
    };
    let r = detached(py, None, |_| {
        let d = FrfLines {
            freqs_hz: &f,
            values: &h,
            weights: w.as_deref(),
            form,
        };
        let c = cross.as_ref().map(|c| FrfLines {
            values: c,
            weights: None,
            ..d
        });
        fit::fit_modes(&d, c.as_ref(), &settings).map_err(input_error)
    })?;
    let out = PyDict::new(py);
    let col = |g: &dyn Fn(&fit::FittedMode) -> f64| -> Vec<f64> { r.modes.iter().map(g).collect() };
    out.set_item("frequency_hz", col(&|m| m.frequency_hz).into_pyarray(py))?;
    out.set_item("damping_ratio", col(&|m| m.damping_ratio).into_pyarray(py))?;
    out.set_item("modal_mass_kg", col(&|m| m.modal_mass_kg).into_pyarray(py))?;
    out.set_item(
        "modal_stiffness_n_per_m",
        col(&|m| m.modal_stiffness_n_per_m).into_pyarray(py),
    )?;
    out.set_item(
        "shape_cavity",
        col(&|m| m.shape_cavity.unwrap_or(f64::NAN)).into_pyarray(py),
    )?;
    out.set_item("pole_re", col(&|m| m.pole.re).into_pyarray(py))?;
    out.set_item("pole_im", col(&|m| m.pole.im).into_pyarray(py))?;
    out.set_item("residue_re", col(&|m| m.residue.re).into_pyarray(py))?;
    out.set_item("residue_im", col(&|m| m.residue.im).into_pyarray(py))?;
    out.set_item(
        "residue_phase_deg",
        col(&|m| m.residue_phase_deg).into_pyarray(py),
    )?;
    out.set_item("frac", col(&|m| m.frac).into_pyarray(py))?;
    out.set_item("mpc", col(&|m| m.mpc).into_pyarray(py))?;
    out.set_item("order", col(&|m| m.order as f64).into_pyarray(py))?;
    out.set_item("upper_residual_m_per_n", r.upper_residual)?;
    out.set_item("lower_residual_per_kg", r.lower_residual)?;
    out.set_item("fit_error", r.fit_error)?;
    out.set_item("fit_error_cross", r.fit_error_cross)?;
    out.set_item("refine_iterations", r.refine_iterations)?;
    let chart = PyDict::new(py);
    let p = &r.chart.poles;
    let cc = |g: &dyn Fn(&fit::ChartPole) -> f64| -> Vec<f64> { p.iter().map(g).collect() };
    chart.set_item("order", cc(&|c| c.order as f64).into_pyarray(py))?;
    chart.set_item("frequency_hz", cc(&|c| c.frequency_hz).into_pyarray(py))?;
    chart.set_item("damping_ratio", cc(&|c| c.damping_ratio).into_pyarray(py))?;
    chart.set_item("pole_re", cc(&|c| c.pole.re).into_pyarray(py))?;
    chart.set_item("pole_im", cc(&|c| c.pole.im).into_pyarray(py))?;
    chart.set_item(
        "stable",
        p.iter()
            .map(|c| c.stable())
            .collect::<Vec<bool>>()
            .into_pyarray(py),
    )?;
    out.set_item("chart", chart)?;
    Ok(out)
}

/// The native part of the `vibrobar` package.
#[pymodule]
fn _vibrobar(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScenario>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(design_map, m)?)?;
    m.add_function(wrap_pyfunction!(regime, m)?)?;
    m.add_function(wrap_pyfunction!(poincare, m)?)?;
    m.add_function(wrap_pyfunction!(lyapunov, m)?)?;
    m.add_function(wrap_pyfunction!(lyapunov_spectrum, m)?)?;
    m.add_function(wrap_pyfunction!(orbit, m)?)?;
    m.add_function(wrap_pyfunction!(continuation, m)?)?;
    m.add_function(wrap_pyfunction!(continuation2, m)?)?;
    m.add_function(wrap_pyfunction!(bifurcation_diagram, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble, m)?)?;
    m.add_function(wrap_pyfunction!(lobes, m)?)?;
    m.add_function(wrap_pyfunction!(lobes_frf, m)?)?;
    m.add_function(wrap_pyfunction!(two_planes::two_plane, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_run, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_table, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_poincare, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_lyapunov, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_lyapunov_spectrum, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_orbit, m)?)?;
    m.add_function(wrap_pyfunction!(two_plane_continuation, m)?)?;
    m.add_function(wrap_pyfunction!(fit_modes, m)?)?;
    m.add_function(wrap_pyfunction!(width_diagram, m)?)?;
    m.add_function(wrap_pyfunction!(time_domain_lobes, m)?)?;
    m.add_function(wrap_pyfunction!(lobe_design, m)?)?;
    m.add_function(wrap_pyfunction!(read_frf, m)?)?;
    m.add_function(wrap_pyfunction!(write_uff58, m)?)?;
    m.add_function(wrap_pyfunction!(frf, m)?)?;
    m.add_function(wrap_pyfunction!(solver_names, m)?)?;
    m.add_function(wrap_pyfunction!(_busy, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DEFAULT_SOLVER", vibrobar_scenario::DEFAULT_SOLVER)?;
    Ok(())
}
