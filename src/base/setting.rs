//! The settings a caller gives a stage, as the stage's messages name them.
//!
//! A stage's error that a setting would fix names that setting by a typed value (the
//! stage's own enum, such as `controller::ControllerSetting`), never by the flag or field
//! a caller spells it with. Its `Display` says the setting in the stage's words
//! ([`Setting::words`]); a caller with its own names for the settings (the command line's
//! flags) renders the same message with them through [`NamesSettings::render`].

/// A setting of a stage that its messages name.
pub trait Setting: Copy {
    /// The stage's words for it, as a message says it ("the column map").
    fn words(self) -> &'static str;
}

/// An error whose message names settings of one stage.
pub trait NamesSettings {
    /// The stage's settings.
    type Setting: Setting;

    /// The message with every setting called by `name` (`Display` is
    /// `render(&Setting::words)`).
    fn render(&self, name: &dyn Fn(Self::Setting) -> &'static str) -> String;
}
