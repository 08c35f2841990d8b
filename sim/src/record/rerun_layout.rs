//! The layout `run.rrd` opens with, written as rerun's blueprint archetypes.
//!
//! Written here rather than with the SDK's blueprint builder because the builder (0.36) cannot
//! set a view's properties, and a time-series view left to its defaults shows 60 s around the
//! time cursor: a build of an hour read through a keyhole. Every plot here spans the whole
//! build ([`TimeAxis`] over an infinite range). The ids are fixed, so the same run gives the
//! same layout.

use rerun::RecordingStream;
use rerun::blueprint::components::{
    ColumnShare, ContainerKind, IncludedContent, PlayState, QueryExpression, RootContainer,
    RowShare, ViewClass,
};
use rerun::datatypes::{TimeRange, TimeRangeBoundary, Uuid};
use rerun::external::re_log_types::BlueprintActivationCommand;
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, TimeAxis, TimePanelBlueprint, ViewBlueprint, ViewContents,
    ViewportBlueprint,
};

/// A view or a container of them; shares size the children along the container's direction.
pub enum Node {
    Row(Vec<(f32, Node)>),
    Column(Vec<(f32, Node)>),
    /// One child shown at a time, the first on opening.
    Tabs(Vec<Node>),
    View(View),
}

pub struct View {
    /// rerun's class: "3D", "2D", "TimeSeries", "TextLog".
    pub class: &'static str,
    pub name: String,
    pub origin: String,
    /// Entity-path queries: "+ world/**" includes, "- world/plan/**" leaves out.
    pub contents: Vec<String>,
}

/// A view of `contents`, each an entity path with `+ ` or `- ` before it or none (included).
pub fn view(class: &'static str, name: &str, origin: &str, contents: &[&str]) -> Node {
    let query = |c: &&str| match c.starts_with("+ ") || c.starts_with("- ") {
        true => c.to_string(),
        false => format!("+ {c}"),
    };
    Node::View(View {
        class,
        name: name.to_string(),
        origin: origin.to_string(),
        contents: contents.iter().map(query).collect(),
    })
}

/// Ids made from a counter: rerun needs them unique within the blueprint, not random.
struct Ids(u128);

impl Ids {
    fn next(&mut self) -> [u8; 16] {
        self.0 += 1;
        (0x5741_414d_7477_696e_0000_0000_0000_0000u128 + self.0).to_be_bytes()
    }
}

fn hyphenated(b: [u8; 16]) -> String {
    let h: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &h[0..8],
        &h[8..12],
        &h[12..16],
        &h[16..20],
        &h[20..32]
    )
}

/// Log `node` and its children to the blueprint stream; returns its path and id.
fn log(
    bp: &RecordingStream,
    node: &Node,
    ids: &mut Ids,
) -> rerun::RecordingStreamResult<(String, [u8; 16])> {
    let id = ids.next();
    match node {
        Node::View(v) => {
            let path = format!("view/{}", hyphenated(id));
            bp.log(
                format!("{path}/ViewContents"),
                &ViewContents::new(v.contents.iter().map(|q| QueryExpression(q.clone().into()))),
            )?;
            bp.log(
                path.as_str(),
                &ViewBlueprint::new(ViewClass(v.class.into()))
                    .with_display_name(v.name.clone())
                    .with_space_origin(v.origin.clone()),
            )?;
            if v.class == "TimeSeries" {
                let whole = TimeRange {
                    start: TimeRangeBoundary::Infinite,
                    end: TimeRangeBoundary::Infinite,
                };
                bp.log(
                    format!("{path}/TimeAxis"),
                    &TimeAxis::new().with_view_range(whole),
                )?;
            }
            Ok((path, id))
        }
        Node::Row(children) | Node::Column(children) => {
            let path = format!("container/{}", hyphenated(id));
            let mut included = Vec::new();
            for (_, child) in children {
                included.push(IncludedContent(log(bp, child, ids)?.0.into()));
            }
            let shares = children.iter().map(|(s, _)| *s);
            let arch = match node {
                Node::Row(_) => ContainerBlueprint::new(ContainerKind::Horizontal)
                    .with_col_shares(shares.map(ColumnShare::from)),
                _ => ContainerBlueprint::new(ContainerKind::Vertical)
                    .with_row_shares(shares.map(RowShare::from)),
            };
            bp.log(path.as_str(), &arch.with_contents(included))?;
            Ok((path, id))
        }
        Node::Tabs(children) => {
            let path = format!("container/{}", hyphenated(id));
            let mut included = Vec::new();
            for child in children {
                included.push(IncludedContent(log(bp, child, ids)?.0.into()));
            }
            let mut arch = ContainerBlueprint::new(ContainerKind::Tabs);
            if let Some(first) = included.first() {
                arch = arch.with_active_tab(first.0.clone());
            }
            bp.log(path.as_str(), &arch.with_contents(included))?;
            Ok((path, id))
        }
    }
}

/// Send `root` as the recording's active and default layout, opened on `timeline` at its end
/// (the finished build; the time panel scrubs back).
pub fn send(
    rec: &RecordingStream,
    root: &Node,
    timeline: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let app = rec
        .store_info()
        .map(|info| info.application_id().clone())
        .unwrap_or_else(|| "waamtwin".into());
    let (bp, storage) = rerun::RecordingStreamBuilder::new(app)
        .blueprint()
        .memory()?;
    // The viewer reads blueprint data on this timeline.
    bp.set_time_sequence("blueprint", 0);
    let (_, root_id) = log(&bp, root, &mut Ids(0))?;
    bp.log(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(Uuid { bytes: root_id }))
            .with_auto_layout(false)
            .with_auto_views(false),
    )?;
    bp.log(
        "time_panel",
        &TimePanelBlueprint::new()
            .with_timeline(timeline)
            .with_play_state(PlayState::Following),
    )?;
    bp.flush_blocking()?;
    let msgs = storage.take();
    let Some(first) = msgs.first() else {
        return Ok(());
    };
    let activation = BlueprintActivationCommand {
        blueprint_id: first.store_id().clone(),
        make_active: true,
        make_default: true,
    };
    rec.send_blueprint(msgs, activation);
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn ids_read_as_uuids() {
        let mut ids = super::Ids(0);
        let s = super::hyphenated(ids.next());
        assert_eq!(s, "5741414d-7477-696e-0000-000000000001");
    }
}
