//! The machine simulator: the other side of the diagnosis. A machine model (TOML) and a
//! measurement plan drive the simulated board of `errmap-drivers` through the same wire
//! frames and decoder as a capture.
//!
//! | module | holds |
//! |---|---|
//! | `physics` | the machine model and every effect's forward formula ([`PhysicsTruth`]) |
//! | `plan` | measurement-plan files, simulating a stream, test points with the truth |
//! | `testplan` | ISO 230-2 test plans: targets with random offsets, the standard test cycle |
//! | `program` | a campaign of lines as a part program visits it (the programs: `controller::program`) |
//! | [`update`] | writing a diagnosis' found effects back into a model |
//! | `job` | the diagnosis as one job: read, thin, simulate, diagnose, update the model |
//! | `rotary`, `rotary_board` | the rotary simulator, and its cycle as a rotary board's frames |
//! | `concealed` | the concealed-effect cases of `datasets/concealed/` |
//! | `error` | [`SimError`] |
//! | `bounds` | the physical range of every number in a model or plan file |

mod bounds;
mod concealed;
mod error;
mod job;
mod physics;
mod plan;
mod program;
mod rotary;
mod rotary_board;
mod rotary_plan;
mod testplan;
mod update;

pub(crate) use bounds::check_numbers;
pub use concealed::{
    Case, Generated, Truth as ConcealedTruth, cases as concealed_cases,
    generate as generate_concealed, nominal as concealed_nominal, plan as concealed_plan,
    write_all as write_concealed,
};
pub use error::SimError;
pub use job::{Against, DiagnoseJob, DiagnoseOutcome, JobError, Thinning, session_file};
pub use physics::{
    Abbe, ColouredNoise, History, LatchDelay, MachineModel, Outliers, PeriodicScale, PhysicsTruth,
    Refraction, Reversal, Scale, ScaleFactor, ThermalDrift, simulate_plan, simulate_rows,
    simulate_session,
};
pub use plan::{PlanSpec, read_plan, simulate_stream, truth_test_points};
pub use program::{LinesProgram, ProgramLine};
pub use rotary::{RotaryAxisModel, RotaryCycle, simulate_rotary};
pub use rotary_board::{
    is_rotary_model, read_rotary_cycle, read_rotary_model, rotary_hello, rotary_stream,
    simulate_rotary_stream,
};
pub use rotary_plan::{MAX_PLAN_TARGETS, RotaryPlan, RotaryPlanConfig, RotaryPlanError};
pub use testplan::{
    CycleStep, PlanField, PlanProblem, Spacing, TestPlan, TestPlanConfig, TestPlanError,
};
pub use update::apply_found_effects;
