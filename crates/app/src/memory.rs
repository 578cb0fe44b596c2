//! Inputs a program holds in memory, given to a job in place of the file of the same role (the
//! Python module's numpy columns and dicts): a trial, an unloaded run, a parameters, effects or
//! truth object. Each carries the label messages and results name it by, as they name a file by
//! its path.

/// A value given in memory with the name it goes by (e.g. `<trial dict>`).
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct InMemory<T> {
    /// The value (a trial, an unloaded run, a JSON object).
    pub value: T,
    /// What messages and results call it in place of a path.
    pub label: String,
}

impl<T> InMemory<T> {
    /// `value`, named `label`.
    pub fn new(value: T, label: impl Into<String>) -> Self {
        Self {
            value,
            label: label.into(),
        }
    }
}
