//! Why a diagnosis could not be made: [`DiagnoseError`].

/// Why a diagnosis could not be made.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    /// One of the tables has no rows.
    #[error("the {which} session has no rows")]
    Empty {
        /// "recorded" or "simulated".
        which: &'static str,
    },
    /// No (run, sample) of the recording occurs in the simulation.
    #[error(
        "no row of the recorded session ({recorded} rows) matches the simulated one ({simulated} rows) on (run, sample)"
    )]
    NoMatch {
        /// Recorded rows.
        recorded: usize,
        /// Simulated rows.
        simulated: usize,
    },
    /// Too few usable rows after matching and filtering.
    #[error("only {usable} usable matched rows (at least {needed} needed): {detail}")]
    TooFewRows {
        /// Usable rows.
        usable: usize,
        /// Needed rows.
        needed: usize,
        /// What was left out.
        detail: String,
    },
    /// Every usable recorded row lies outside any run (`run` = 0): no line was measured
    /// (issue 28: such a session was diagnosed, its lines without coordinates).
    #[error(
        "none of the {rows} usable recorded rows lies inside a run (run = 0 on every row): no line was measured"
    )]
    NoRuns {
        /// Usable rows.
        rows: usize,
    },
    /// The recorded rows switch between axes so often that they are no single-axis
    /// session (issue 28: rows alternating X, Y, X, Y… were diagnosed on half of them).
    #[error(
        "the recorded rows change axis {switches} times in {rows} rows: a session measures one axis (interleaved or damaged rows?)"
    )]
    AxesInterleaved {
        /// Changes of axis between consecutive matched rows.
        switches: usize,
        /// Matched rows.
        rows: usize,
    },
    /// A setting is outside its range.
    #[error("invalid diagnose setting: {0}")]
    Config(String),
    /// A fitted parameter came out NaN or infinite: a bug of the fit, not of the input
    /// (which is validated at the door). Reported instead of written, since JSON would
    /// turn it into `null`.
    #[error(
        "bug in errmap: the fitted {param} of {effect} is {value} (not finite); nothing was written"
    )]
    NonFinite {
        /// Effect id.
        effect: String,
        /// Parameter name.
        param: String,
        /// The value or its σ.
        value: f64,
    },
    /// A fit's parameters do not make the effect its variant names: a bug of the fit.
    #[error("bug in errmap: {0}; nothing was written")]
    Effect(#[from] crate::base::EffectParamError),
}
