//! `errmap artefact`: plate fits on the SDSS plug-plate measurements (real CMM data read
//! from `../shared/data/sdss_plugplate/`, skipped when absent, never copied), known
//! answers on simulated campaigns, bad input refused as `artefact.md` says.

mod bad_input;
mod concealed;
mod identify;
mod joint;
mod known;
mod sdss;
mod selfcal;
