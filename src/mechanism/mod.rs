//! Mechanism: exact Geneva kinematics, crank speed profiles, the continuous multi-cycle truth
//! trajectory and an optional pin–slot clearance dynamics model with bearing friction.

pub mod config;
pub mod contact;
pub mod drive_speed;
pub mod dynamics;
pub mod dynamics_config;
pub mod effects;
pub mod engagements;
pub mod error;
pub mod kinematics;
pub mod trajectory;

pub use config::MechanismConfig;
pub use contact::{ContactLaw, ContactModel};
pub use drive_speed::{parse_drive_table_csv, CrankMotion, DriveSpeedConfig};
pub use dynamics_config::{
    AxisRunoutConfig, CrankConfig, CrankModel, DiscVibrationConfig, DynamicsConfig,
    VibrationComponent,
};
pub use error::MechanismError;
pub use kinematics::{CrankState, Geneva, GenevaKind, WheelState};
pub use trajectory::{stable_step_limit_s, Mechanism, MotionSample, Phase};
