//! `fields.h5`: the wall's temperature in the VTKHDF 2.0 layout, which ParaView (≥ 5.12) and
//! VTK's `vtkHDFReader` open directly, written by the pure-Rust `hdf5-pure` (no system HDF5;
//! the choice is argued in docs/ARCHITECTURE.md).
//!
//! `/VTKHDF` is a transient UnstructuredGrid: the deposited wall as triangles over the path
//! points (mm), one geometry shared by every step (all offsets 0), and per step the point data
//! `temperature_c` (NaN where not yet laid) and `laid` (1 once laid, for ParaView's Threshold).
//! Static point data: `preheat_c`, `deposit_mm`, `layer`. Outside `/VTKHDF`, which VTK ignores,
//! `/path` holds the per-point results as plain datasets, each with a `unit` attribute.
//!
//! `fields.xdmf` beside it describes the same datasets as an XDMF 2 temporal collection, for
//! the readers that predate VTKHDF 2.0 (ParaView 5.11, Debian 12's, reads only the first step
//! of the 2.0 file): each step a grid whose geometry and triangles are the shared datasets and
//! whose temperature is a hyperslab of the per-step array. No data is written twice.

use super::{Moment, Scene, Sink};
use crate::error::{Error, Result};
use crate::output::RunDir;
use hdf5_pure::{AttrValue, FileBuilder};

/// VTK's cell type for a triangle.
const VTK_TRIANGLE: u8 = 5;

#[derive(Default)]
pub struct VtkHdfSink;

fn fail(e: impl std::fmt::Display) -> Error {
    Error::failure(format!("fields.h5: {e}"))
}

fn unit(u: &str) -> AttrValue {
    AttrValue::AsciiString(u.into())
}

impl Sink for VtkHdfSink {
    fn begin(&mut self, _scene: &Scene, _dir: &RunDir) -> Result<()> {
        Ok(())
    }

    /// The frames are already in the scene; the file is written whole at the end.
    fn moment(&mut self, _scene: &Scene, _m: Moment<'_>) -> Result<()> {
        Ok(())
    }

    fn finish(self: Box<Self>, scene: &Scene, dir: &mut RunDir) -> Result<()> {
        let bytes = fields_h5(scene)?;
        dir.write("fields.h5", &bytes)?;
        dir.write("fields.xdmf", fields_xdmf(scene, "fields.h5").as_bytes())?;
        Ok(())
    }
}

pub fn fields_h5(scene: &Scene) -> Result<Vec<u8>> {
    let np = scene.points.len();
    let nc = scene.wall.len();
    let steps = scene.frames.len().max(1);
    let mut file = FileBuilder::new();

    let mut vtk = file.create_group("VTKHDF");
    vtk.set_attr("Version", AttrValue::I64Array(vec![2, 0]));
    vtk.set_attr("Type", AttrValue::AsciiString("UnstructuredGrid".into()));
    vtk.create_dataset("NumberOfPoints")
        .with_i64_data(&[np as i64]);
    vtk.create_dataset("NumberOfCells")
        .with_i64_data(&[nc as i64]);
    vtk.create_dataset("NumberOfConnectivityIds")
        .with_i64_data(&[3 * nc as i64]);
    let points: Vec<f64> = scene.points.iter().flat_map(|p| p.position_mm).collect();
    vtk.create_dataset("Points")
        .with_f64_data(&points)
        .with_shape(&[np as u64, 3]);
    vtk.create_dataset("Types")
        .with_u8_data(&vec![VTK_TRIANGLE; nc]);
    let connectivity: Vec<i64> = scene.wall.iter().flatten().map(|&v| v as i64).collect();
    vtk.create_dataset("Connectivity")
        .with_i64_data(&connectivity);
    let offsets: Vec<i64> = (0..=nc as i64).map(|k| 3 * k).collect();
    vtk.create_dataset("Offsets").with_i64_data(&offsets);

    // Per step: the temperature and whether each point is laid; static: the plan's results.
    let mut temperature = Vec::with_capacity(steps * np);
    let mut laid = Vec::with_capacity(steps * np);
    if scene.frames.is_empty() {
        temperature.extend(std::iter::repeat_n(f32::NAN, np));
        laid.extend(std::iter::repeat_n(1u8, np));
    }
    for f in &scene.frames {
        temperature.extend_from_slice(&f.temperature_c);
        laid.extend((0..np).map(|i| u8::from(i < f.laid)));
    }
    let mut data = vtk.create_group("PointData");
    data.create_dataset("temperature_c")
        .with_f32_data(&temperature);
    data.create_dataset("laid").with_u8_data(&laid);
    let preheat: Vec<f32> = scene.points.iter().map(|p| p.preheat_c as f32).collect();
    data.create_dataset("preheat_c").with_f32_data(&preheat);
    let deposit: Vec<f32> = scene.points.iter().map(|p| p.deposit_mm as f32).collect();
    data.create_dataset("deposit_mm").with_f32_data(&deposit);
    let layer: Vec<i64> = scene.points.iter().map(|p| p.layer as i64).collect();
    data.create_dataset("layer").with_i64_data(&layer);
    vtk.add_group(data.finish());

    let zeros = vec![0i64; steps];
    let mut st = vtk.create_group("Steps");
    st.set_attr("NSteps", AttrValue::I64(steps as i64));
    let values: Vec<f64> = if scene.frames.is_empty() {
        vec![scene.build_s]
    } else {
        scene.frames.iter().map(|f| f.t_s).collect()
    };
    st.create_dataset("Values").with_f64_data(&values);
    st.create_dataset("PartOffsets").with_i64_data(&zeros);
    st.create_dataset("NumberOfParts")
        .with_i64_data(&vec![1i64; steps]);
    st.create_dataset("PointOffsets").with_i64_data(&zeros);
    st.create_dataset("CellOffsets")
        .with_i64_data(&zeros)
        .with_shape(&[steps as u64, 1]);
    st.create_dataset("ConnectivityIdOffsets")
        .with_i64_data(&zeros)
        .with_shape(&[steps as u64, 1]);
    let mut pdo = st.create_group("PointDataOffsets");
    let per_step: Vec<i64> = (0..steps as i64).map(|k| k * np as i64).collect();
    pdo.create_dataset("temperature_c").with_i64_data(&per_step);
    pdo.create_dataset("laid").with_i64_data(&per_step);
    for name in ["preheat_c", "deposit_mm", "layer"] {
        pdo.create_dataset(name).with_i64_data(&zeros);
    }
    st.add_group(pdo.finish());
    vtk.add_group(st.finish());
    file.add_group(vtk.finish());

    let mut path = file.create_group("path");
    let column = |f: &dyn Fn(&super::PointRecord) -> f64| -> Vec<f64> {
        scene.points.iter().map(f).collect()
    };
    let columns: [(&str, &str, Vec<f64>); 12] = [
        ("x_mm", "mm", column(&|p| p.position_mm[0])),
        ("y_mm", "mm", column(&|p| p.position_mm[1])),
        ("z_mm", "mm", column(&|p| p.position_mm[2])),
        ("t_s", "s", column(&|p| p.t_s)),
        ("deposit_mm", "mm", column(&|p| p.deposit_mm)),
        ("preheat_c", "degC", column(&|p| p.preheat_c)),
        ("power_w", "W", column(&|p| p.power_w)),
        ("dwell_s", "s", column(&|p| p.dwell_s)),
        ("pace", "1", column(&|p| p.pace)),
        ("drop", "1", column(&|p| f64::from(u8::from(p.in_drop)))),
        ("layer", "1", column(&|p| p.layer as f64)),
        ("generator", "1", column(&|p| p.generator as f64)),
    ];
    for (name, u, v) in &columns {
        path.create_dataset(name)
            .with_f64_data(v)
            .set_attr("unit", unit(u));
    }
    path.set_attr("interpass_max_c", AttrValue::F64(scene.interpass_c));
    file.add_group(path.finish());
    file.set_attr("title", AttrValue::AsciiString(scene.title.clone()));
    file.finish().map_err(fail)
}

/// The XDMF 2 description of `h5` (written by [`fields_h5`] from the same scene).
pub fn fields_xdmf(scene: &Scene, h5: &str) -> String {
    use std::fmt::Write;
    let np = scene.points.len();
    let nc = scene.wall.len();
    let times: Vec<f64> = if scene.frames.is_empty() {
        vec![scene.build_s]
    } else {
        scene.frames.iter().map(|f| f.t_s).collect()
    };
    let steps = times.len();
    let item = |dims: &str, kind: &str, precision: usize, path: &str| {
        format!(
            "<DataItem Dimensions=\"{dims}\" NumberType=\"{kind}\" Precision=\"{precision}\" \
             Format=\"HDF\">{h5}:/VTKHDF/{path}</DataItem>"
        )
    };
    let per_step = |name: &str, kind: &str, precision: usize, k: usize| {
        format!(
            "<Attribute Name=\"{name}\" AttributeType=\"Scalar\" Center=\"Node\">\
             <DataItem ItemType=\"HyperSlab\" Dimensions=\"{np}\" Type=\"HyperSlab\">\
             <DataItem Dimensions=\"3 1\" Format=\"XML\">{} 1 {np}</DataItem>{}</DataItem></Attribute>",
            k * np,
            item(
                &(steps * np).to_string(),
                kind,
                precision,
                &format!("PointData/{name}")
            )
        )
    };
    let fixed = |name: &str, kind: &str, precision: usize| {
        format!(
            "<Attribute Name=\"{name}\" AttributeType=\"Scalar\" Center=\"Node\">{}</Attribute>",
            item(
                &np.to_string(),
                kind,
                precision,
                &format!("PointData/{name}")
            )
        )
    };
    let mut x = String::from(
        "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"2.0\">\n<Domain>\n\
         <Grid Name=\"wall\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for (k, t) in times.iter().enumerate() {
        let _ = writeln!(
            x,
            "<Grid Name=\"step {k}\" GridType=\"Uniform\"><Time Value=\"{t}\"/>\
             <Topology TopologyType=\"Triangle\" NumberOfElements=\"{nc}\">{}</Topology>\
             <Geometry GeometryType=\"XYZ\">{}</Geometry>{}{}{}{}{}</Grid>",
            item(&(3 * nc).to_string(), "Int", 8, "Connectivity"),
            item(&format!("{np} 3"), "Float", 8, "Points"),
            per_step("temperature_c", "Float", 4, k),
            per_step("laid", "UChar", 1, k),
            fixed("preheat_c", "Float", 4),
            fixed("deposit_mm", "Float", 4),
            fixed("layer", "Int", 8),
        );
    }
    x.push_str("</Grid>\n</Domain>\n</Xdmf>\n");
    x
}
