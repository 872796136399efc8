//! The settings of the controller stage that its messages name ([`ControllerSetting`]).

/// A setting of a controller job or a part program that a refusal names, in the stage's
/// words (`base::Setting`); the command line names each by its flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerSetting {
    /// The dialect a part program is written in ([`super::program::dialect`]).
    ProgramDialect,
    /// The digital output switched at each dwell (`ProgramOptions::mark_output`).
    MarkOutput,
    /// The stop at each target of a test plan (`TestPlanConfig::dwell_s`).
    Dwell,
    /// A table per direction of approach (an update's `bidirectional`).
    Bidirectional,
    /// The angle between the points of a modulo table (`ModuloSpec::step_deg`).
    Step,
    /// The axis a Siemens table is for (`ModuloSpec::siemens_axis`).
    SiemensAxis,
    /// The column of a HEIDENHAIN table (`ModuloSpec::axis_name`).
    AxisName,
}

impl crate::base::Setting for ControllerSetting {
    fn words(self) -> &'static str {
        match self {
            ControllerSetting::ProgramDialect => "the program's dialect",
            ControllerSetting::MarkOutput => "the mark output",
            ControllerSetting::Dwell => "the dwell",
            ControllerSetting::Bidirectional => "a table per direction",
            ControllerSetting::Step => "the step",
            ControllerSetting::SiemensAxis => "the Siemens axis name",
            ControllerSetting::AxisName => "the table's axis name",
        }
    }
}
