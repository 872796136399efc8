//! The library's settings as the command line names them. Each stage names a setting
//! its refusal is about by a typed value in its own words (`errmap::base::Setting`:
//! `ControllerSetting`, `ExportSetting`, `ImportSetting`); [`Flag`] gives each its flag,
//! and [`in_flags`] says an error that names settings (`errmap::base::NamesSettings`)
//! with those flags, as `main` prints it.

use errmap::base::NamesSettings;
use errmap::controller::ControllerSetting;
use errmap::export::ExportSetting;
use errmap::import::ImportSetting;
use errmap::interp::InterpSetting;

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
            ExportSetting::Reference => "--reference",
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

impl Flag for InterpSetting {
    fn flag(self) -> &'static str {
        match self {
            InterpSetting::Order => "--order",
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
        .or_else(|| as_flags::<errmap::interp::InterpError>(cause))
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// Every long flag of the command line, on any subcommand.
    fn long_flags() -> Vec<String> {
        fn walk(cmd: &clap::Command, out: &mut Vec<String>) {
            out.extend(
                cmd.get_arguments()
                    .filter_map(|a| a.get_long().map(|l| format!("--{l}"))),
            );
            for sub in cmd.get_subcommands() {
                walk(sub, out);
            }
        }
        let mut out = Vec::new();
        walk(&super::super::Cli::command(), &mut out);
        out
    }

    /// Each setting's flag is one the command line has (a renamed flag cannot leave a
    /// message naming the old one).
    #[test]
    fn every_setting_names_a_flag_of_the_command_line() {
        use super::Flag;
        use errmap::controller::ControllerSetting as C;
        use errmap::export::ExportSetting as E;
        use errmap::import::ImportSetting as I;
        use errmap::interp::InterpSetting as P;
        let flags = long_flags();
        let named = [
            C::ProgramDialect.flag(),
            C::MarkOutput.flag(),
            C::Dwell.flag(),
            C::Bidirectional.flag(),
            C::Step.flag(),
            C::SiemensAxis.flag(),
            C::AxisName.flag(),
            E::Line.flag(),
            E::Ends.flag(),
            E::Reference.flag(),
            I::ColumnMap.flag(),
            I::ErrorSign.flag(),
            I::Delimiter.flag(),
            I::DecimalComma.flag(),
            I::Format.flag(),
            P::Order.flag(),
        ];
        for f in named {
            assert!(flags.iter().any(|g| g == f), "{f} is no flag of errmap");
        }
    }

    /// A library error that names a setting reaches the user with the flag, in the shape
    /// `main` prints.
    #[test]
    fn the_printed_message_names_the_flag() {
        let e = anyhow::Error::from(errmap::interp::InterpError::TooLargeForAuto {
            nodes: 64_000,
            max: 50_000,
        });
        let printed = super::super::message(&e);
        assert!(
            printed.ends_with("give the degrees (--order MxNxQ)"),
            "{printed}"
        );
        assert_eq!(
            e.to_string().rsplit(" (").next(),
            Some("the Lagrange order MxNxQ)"),
            "the library's own words"
        );
        let e = anyhow::Error::from(errmap::import::MapError::NoTarget).context("import");
        assert_eq!(
            super::super::message(&e),
            "import: --map needs target=COLUMN"
        );
    }
}
