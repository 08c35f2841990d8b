//! One module per subcommand; each is a library function a test can call.

pub mod calibrate;
pub mod checkpoint;
pub mod cost;
pub mod demo;
pub mod dwell;
pub mod export;
pub mod follow;
pub mod geodesic;
pub mod inspect;
pub mod mesh;
pub mod plan;
pub mod replay;
pub mod replay_plan;
pub mod simulate;
pub mod skeleton;
pub mod study;
pub mod tube;
