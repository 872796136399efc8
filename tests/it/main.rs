//! errmap's integration tests, one binary (every test binary links polars; one link
//! instead of ten saves CI minutes). Each module is one area; the diagnosis has its own
//! binary in `tests/diagnosis/`.

mod acceptance;
mod acquisition;
mod artefact;
mod campaign;
mod certificate;
mod circular;
mod cli;
mod dialects;
mod exit_codes;
mod experiment;
mod export;
mod export_dialects;
mod export_step;
mod gp;
mod help;
mod history;
mod history_crash;
mod import;
mod import_dialects;
mod interp;
mod iso230;
mod layers;
mod live_view;
mod node_noise;
mod physics;
mod probing;
mod readme_tour;
mod robust40;
mod robust_io;
mod robust_outputs;
mod robustness;
mod rotary;
mod rtl;
mod soak;
mod stream;
mod table2;
mod tables;
mod testplan;
mod testplan_lines;
mod uncertainty;
mod untidy;
mod util;
mod volumetric;
mod volumetric_campaign;
mod volumetric_degree;
mod volumetric_export;
mod volumetric_random;
mod volumetric_thermal;
#[cfg(feature = "workbench")]
mod workbench;
#[cfg(feature = "workbench")]
mod workbench_browser;
#[cfg(feature = "workbench")]
mod workbench_rotary;
