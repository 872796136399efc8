//! The library's settings as the command line names them. Each stage names a setting
//! its refusal is about by a typed value in its own words (`errmap::base::Setting`:
//! `ControllerSetting`, `ExportSetting`, `ImportSetting`); [`Flag`] gives each its flag,
//! and [`in_flags`] says an error that names settings (`errmap::base::NamesSettings`)
//! with those flags, as `main` prints it.

use errmap::base::NamesSettings;
use errmap::controller::ControllerSetting;
use errmap::export::ExportSetting;
use errmap::import::ImportSetting;

/// A library setting's flag.
pub(crate) trait Flag: Copy {
    fn flag(self) -> &'static str;
}

impl Flag for ControllerSetting {
    fn flag(self) -> &'static str {
        match self {
            ControllerSetting::ProgramDialect => "--dialect",
            ControllerSetting::MarkOutput => "--mark-output",
            ControllerSetting::Dwell => "--dwell-s",
            ControllerSetting::Bidirectional => "--bidirectional",
            ControllerSetting::Step => "--step",
            ControllerSetting::SiemensAxis => "--siemens-axis",
            ControllerSetting::AxisName => "--axis-name",
        }
    }
}

impl Flag for ExportSetting {
    fn flag(self) -> &'static str {
        match self {
            ExportSetting::Line => "--at",
            ExportSetting::Ends => "--ends",
        }
    }
}

impl Flag for ImportSetting {
    fn flag(self) -> &'static str {
        match self {
            ImportSetting::ColumnMap => "--map",
            ImportSetting::ErrorSign => "--error-sign",
            ImportSetting::Delimiter => "--delimiter",
            ImportSetting::DecimalComma => "--decimal-comma",
            ImportSetting::Format => "--format",
        }
    }
}

/// `e`'s message with its settings called by their flags.
pub(crate) fn said<E: NamesSettings>(e: &E) -> String
where
    E::Setting: Flag,
{
    e.render(&Flag::flag)
}

/// A library error that names settings, said with the flags (`None`: another error).
pub(crate) fn in_flags(cause: &(dyn std::error::Error + 'static)) -> Option<String> {
    fn as_flags<E>(cause: &(dyn std::error::Error + 'static)) -> Option<String>
    where
        E: NamesSettings + std::error::Error + 'static,
        E::Setting: Flag,
    {
        cause.downcast_ref::<E>().map(said)
    }
    use errmap::controller::{UpdateError, modulo::ModuloError, program};
    as_flags::<program::ProgramError>(cause)
        .or_else(|| as_flags::<program::ParseDialectError>(cause))
        .or_else(|| as_flags::<UpdateError>(cause))
        .or_else(|| as_flags::<ModuloError>(cause))
        .or_else(|| as_flags::<errmap::export::ChooseLineError>(cause))
        .or_else(|| as_flags::<errmap::export::ExportError>(cause))
        .or_else(|| as_flags::<errmap::import::ImportError>(cause))
        .or_else(|| as_flags::<errmap::import::MapError>(cause))
}
