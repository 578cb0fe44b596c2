//! OpenSim files: the identified muscles of an `.osim` model in and out, and OpenSim storage
//! (`.sto` / `.mot`) tables.
//!
//! * [`osim`]: the soleus and gastrocnemii of an OpenSim model (`Thelen2003Muscle`,
//!   `Millard2012EquilibriumMuscle`) as surae's [`muscle_model::ModelParams`], and a copy of the
//!   model with identified values written into it, byte for byte the same elsewhere.
//! * [`sto`]: reading OpenSim storage files (header versions 1 and 2, columns by name) and
//!   writing them with a version 1 header.
//!
//! Every error names the file, and the line and column (1-based) where that applies.
//!
//! # Example
//!
//! ```
//! use opensim_files::{osim_params, OsimMuscleNames};
//! use muscle_model::{ModelParams, Muscle};
//!
//! let text = r#"<OpenSimDocument Version="40000"><Model name="m"><ForceSet><objects>
//!   <Thelen2003Muscle name="soleus_r">
//!     <max_isometric_force>3000</max_isometric_force>
//!     <pennation_angle_at_optimal>0.4</pennation_angle_at_optimal>
//!   </Thelen2003Muscle>
//!   <Thelen2003Muscle name="med_gas_r"/>
//!   <Thelen2003Muscle name="lat_gas_r"/>
//! </objects></ForceSet></Model></OpenSimDocument>"#;
//! let p = osim_params(text, "m.osim", &OsimMuscleNames::default(), &ModelParams::nominal()).unwrap();
//! assert_eq!(p.muscle(Muscle::Sol).fom_n, 3000.0);
//! assert!((p.muscle(Muscle::Sol).alpha_deg - 0.4f64.to_degrees()).abs() < 1e-12);
//! // what the file does not give stays as it was
//! assert_eq!(p.muscle(Muscle::Sol).lst_m, ModelParams::nominal().muscle(Muscle::Sol).lst_m);
//! ```

pub mod osim;
pub mod sto;

pub use osim::{osim_params, write_identified_osim, OsimMuscleNames, SUPPORTED_MUSCLE_TYPES};
pub use sto::{read_sto, write_sto, StoTable};

/// What can go wrong reading or writing an OpenSim file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OpenSimError {
    /// A syntax or value error at a place in a file.
    #[error("{file}:{line}:{column}: {message}")]
    At {
        /// The file (as named by the caller).
        file: String,
        /// Line, from 1.
        line: u32,
        /// Column, from 1.
        column: u32,
        /// What is wrong.
        message: String,
    },
    /// A problem with a whole file (no position applies).
    #[error("{file}: {message}")]
    File {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A muscle is missing, of an unsupported type or has non-physical values.
    #[error("{file}: muscle `{muscle}`: {message}")]
    Muscle {
        /// The file.
        file: String,
        /// The muscle's name in the model.
        muscle: String,
        /// What is wrong.
        message: String,
    },
    /// A key of the muscle-name map is not `sol`, `gm` or `gl`.
    #[error("osim_muscles: `{key}` is not one of sol, gm, gl")]
    MuscleKey {
        /// The key given.
        key: String,
    },
}

impl OpenSimError {
    pub(crate) fn at(file: &str, pos: roxmltree::TextPos, message: impl Into<String>) -> Self {
        OpenSimError::At {
            file: file.to_string(),
            line: pos.row,
            column: pos.col,
            message: message.into(),
        }
    }
}
