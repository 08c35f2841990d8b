pub mod material;
pub mod network;
