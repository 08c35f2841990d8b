//! The ply reader: any bytes give a mesh or a FormatError, never a panic or an allocation the
//! input only claims; a mesh read is then checked as a part would be.
#![no_main]
use libfuzzer_sys::fuzz_target;
use planner::io::{MeshFormat, read_mesh};

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = read_mesh(data, MeshFormat::Ply) {
        let _ = planner::mesh::Part::from_mesh(mesh, planner::mesh::LowerLoop::LowestZ);
    }
});
