//! `[live.opcua]`: the probes read from the cell's OPC UA server instead of the probe file.
//!
//! async-opcua's client runs on a tokio runtime of its own thread; it subscribes to one node
//! per probe (sampling on every change, the source timestamp a trigger too, so a reading equal
//! to the last one still arrives), and hands each value over a channel. [`Subscription::look`]
//! turns them into rows in time order: a row at a source timestamp is whole once every node has
//! sent that time or a later one (each node's values come in order), or after [`ROW_WAIT`]
//! with one missing (that probe then reads nothing in the row). A server that goes away is
//! reconnected with back-off (0.5 s doubling to 4 s) and the subscription made again; what it
//! sends again after that (its current values, or rows it serves twice) is counted, not fed.

use ::opcua::client::{ClientBuilder, DataChangeCallback, IdentityToken, MonitoredItem};
use ::opcua::types::{
    DataChangeFilter, DataChangeTrigger, DataValue, EndpointDescription, ExtensionObject,
    MessageSecurityMode, MonitoredItemCreateRequest, MonitoringMode, MonitoringParameters, NodeId,
    ReadValueId, TimestampsToReturn, UserTokenPolicy,
};
use std::collections::BTreeMap;
use std::str::FromStr;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::scenario::replay::Opcua;

/// How long a row waits for a node that has sent nothing at its time.
pub const ROW_WAIT: Duration = Duration::from_secs(2);
/// 100 ns ticks from 1601-01-01 (OPC UA's epoch) to 1970-01-01.
const UNIX_EPOCH_TICKS: i64 = 116_444_736_000_000_000;
/// Values queued on the server per node between two publishes: a twin that falls behind loses
/// nothing while its client thread keeps asking.
const QUEUE: u32 = 10_000;

/// What the client thread says.
enum Event {
    Value { node: usize, ticks: i64, value: f64 },
    Lost(String),
    Reconnected,
    Failed(String),
}

/// The subscription and the rows it has not yet handed on.
pub struct Subscription {
    rx: mpsc::Receiver<Event>,
    _client: Option<std::thread::JoinHandle<()>>,
    origin_ticks: i64,
    /// The probe each node reads.
    probe_of: Vec<usize>,
    probes: usize,
    /// Each node's latest source timestamp.
    latest: Vec<Option<i64>>,
    /// Rows not yet whole: ticks → (when first seen, a value per node).
    pending: BTreeMap<i64, (Instant, Vec<Option<f64>>)>,
    /// The latest row handed on.
    handed: Option<i64>,
    pub counts: super::OpcuaCounts,
}

/// A row handed on: build time, s, and a value per probe.
pub type Row = (f64, Vec<Option<f64>>);

impl Subscription {
    /// Parse the node ids and start the client thread; it connects (and retries) by itself.
    pub fn start(o: &Opcua, probes: usize) -> Result<Subscription, String> {
        let nodes: Vec<NodeId> = o
            .nodes
            .iter()
            .map(|(_, id)| {
                NodeId::from_str(id).map_err(|_| {
                    format!(
                        "[live.opcua] nodes: \"{id}\" is not a node id; expected e.g. \
                         \"ns=2;s=tc1\" or \"ns=2;i=1001\""
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        let (tx, rx) = mpsc::channel();
        let (endpoint, interval) = (
            o.endpoint.clone(),
            Duration::from_secs_f64(o.publishing_interval_s),
        );
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| format!("cannot start the OPC UA client's runtime: {e}"))?;
        let thread = std::thread::Builder::new()
            .name("opcua".into())
            .spawn(move || runtime.block_on(client(endpoint, nodes, interval, tx)))
            .map_err(|e| format!("cannot start the OPC UA client's thread: {e}"))?;
        let origin_ticks = (o.time_origin_unix_s * 1e7).round() as i64 + UNIX_EPOCH_TICKS;
        let probe_of = o.nodes.iter().map(|&(k, _)| k).collect();
        let mut sub = Subscription::on(rx, origin_ticks, probe_of, probes);
        sub._client = Some(thread);
        Ok(sub)
    }

    /// The rows of what comes over `rx`.
    fn on(
        rx: mpsc::Receiver<Event>,
        origin_ticks: i64,
        probe_of: Vec<usize>,
        probes: usize,
    ) -> Subscription {
        Subscription {
            rx,
            _client: None,
            origin_ticks,
            latest: vec![None; probe_of.len()],
            probe_of,
            probes,
            pending: BTreeMap::new(),
            handed: None,
            counts: super::OpcuaCounts::default(),
        }
    }

    /// Rows are never handed on at or before `t_s` (a resumed run's last fed row).
    pub fn after(&mut self, t_s: Option<f64>) {
        self.handed = t_s.map(|t| self.origin_ticks + (t * 1e7).round() as i64);
    }

    /// The rows that are whole now, in time order, and what the connection said since the
    /// last look (Err: the client gave up, a failure).
    pub fn look(&mut self) -> Result<(Vec<Row>, Vec<String>), String> {
        let mut said = Vec::new();
        while let Ok(e) = self.rx.try_recv() {
            match e {
                Event::Value { node, ticks, value } => self.take(node, ticks, value),
                Event::Lost(why) => {
                    said.push(format!("connection lost ({why}); reconnecting"));
                    if self.counts.lost.len() < 100 {
                        self.counts.lost.push(why);
                    }
                }
                Event::Reconnected => {
                    self.counts.reconnects += 1;
                    said.push("reconnected; subscription made again".into());
                }
                Event::Failed(why) => return Err(why),
            }
        }
        Ok((self.whole(), said))
    }

    fn take(&mut self, node: usize, ticks: i64, value: f64) {
        let again = self.latest[node].is_some_and(|l| ticks <= l)
            || self.handed.is_some_and(|h| ticks <= h);
        if again {
            self.counts.repeated += 1;
            return;
        }
        self.latest[node] = Some(ticks);
        let n = self.latest.len();
        let row = self
            .pending
            .entry(ticks)
            .or_insert_with(|| (Instant::now(), vec![None; n]));
        row.1[node] = Some(value);
    }

    /// Hand on the rows every node has passed, and those that waited long enough.
    fn whole(&mut self) -> Vec<Row> {
        let passed = self.latest.iter().copied().min().flatten();
        let mut out = Vec::new();
        while let Some((&ticks, (seen, _))) = self.pending.first_key_value() {
            let complete = passed.is_some_and(|p| ticks <= p);
            if !complete && seen.elapsed() < ROW_WAIT {
                break;
            }
            let (_, (_, values)) = self.pending.pop_first().expect("a first row");
            if values.iter().any(Option::is_none) {
                self.counts.rows_incomplete += 1;
            }
            let mut row = vec![None; self.probes];
            for (k, v) in self.probe_of.iter().zip(values) {
                row[*k] = v;
            }
            self.handed = Some(ticks);
            out.push(((ticks - self.origin_ticks) as f64 * 1e-7, row));
        }
        out
    }
}

/// The client: connect (retrying without end, with back-off), subscribe, and pass on every
/// value and every change of the connection until the receiver is gone.
async fn client(endpoint: String, nodes: Vec<NodeId>, interval: Duration, tx: mpsc::Sender<Event>) {
    // Security mode None needs no certificate, but the client keeps its (empty) trust folders
    // somewhere: one folder for every run, not one left behind per process.
    let pki = std::env::temp_dir().join("waamtwin-opcua-pki");
    let built = ClientBuilder::new()
        .application_name("waamtwin follow")
        .application_uri("urn:waamtwin:follow")
        .pki_dir(pki)
        .create_sample_keypair(false)
        .trust_server_certs(true)
        .session_retry_limit(-1)
        .session_retry_initial(Duration::from_millis(500))
        .session_retry_max(Duration::from_secs(4))
        .recreate_subscriptions(false)
        .client();
    let mut client = match built {
        Ok(c) => c,
        Err(e) => {
            let _ = tx.send(Event::Failed(format!("OPC UA client: {e:?}")));
            return;
        }
    };
    let description: EndpointDescription = (
        endpoint.as_str(),
        "None",
        MessageSecurityMode::None,
        UserTokenPolicy::anonymous(),
    )
        .into();
    let (session, event_loop) =
        match client.connect_to_endpoint_directly(description, IdentityToken::Anonymous) {
            Ok(s) => s,
            Err(e) => {
                let _ = tx.send(Event::Failed(format!("{endpoint}: {e}")));
                return;
            }
        };
    // A new session (the first, or one after the server came back without the old one) gets
    // the subscription made anew here; a reactivated session kept its own on the server.
    use ::opcua::client::{SessionConnectMode as Mode, SessionPollResult as P};
    use futures::StreamExt;
    let nodes = std::sync::Arc::new(nodes);
    let mut stream = std::pin::pin!(event_loop.enter());
    let mut first = true;
    while let Some(r) = stream.next().await {
        let said = match r {
            Ok(P::ConnectionLost(code)) => Some(Event::Lost(format!("{code}"))),
            Ok(P::Reconnected(mode)) => {
                if matches!(mode, Mode::NewSession(_)) {
                    let (session, nodes, tx) = (session.clone(), nodes.clone(), tx.clone());
                    let endpoint = endpoint.clone();
                    tokio::spawn(async move {
                        if let Err(why) = subscribe(&session, &nodes, interval, tx.clone()).await {
                            let _ = tx.send(Event::Failed(format!("{endpoint}: {why}")));
                        }
                    });
                }
                (!std::mem::take(&mut first)).then_some(Event::Reconnected)
            }
            Err(code) => Some(Event::Failed(format!("{endpoint}: {code}"))),
            _ => None,
        };
        if let Some(e) = said
            && tx.send(e).is_err()
        {
            return;
        }
    }
}

/// One subscription, one monitored item per node: every change sent (its source timestamp
/// a change too), queued on the server while the client is away between publishes.
async fn subscribe(
    session: &::opcua::client::Session,
    nodes: &[NodeId],
    interval: Duration,
    tx: mpsc::Sender<Event>,
) -> Result<(), String> {
    let sender = std::sync::Mutex::new(tx);
    let callback = DataChangeCallback::new(move |dv: DataValue, item: &MonitoredItem| {
        let node = item.client_handle() as usize - 1;
        let (Some(v), Some(ts)) = (
            dv.value.as_ref().and_then(|v| v.as_f64()),
            dv.source_timestamp,
        ) else {
            return;
        };
        if v.is_finite()
            && let Ok(tx) = sender.lock()
        {
            let _ = tx.send(Event::Value {
                node,
                ticks: ts.checked_ticks(),
                value: v,
            });
        }
    });
    let id = session
        .create_subscription(interval, 600, 30, 0, 0, true, callback)
        .await
        .map_err(|e| format!("cannot subscribe: {e}"))?;
    let filter = ExtensionObject::from_message(DataChangeFilter {
        trigger: DataChangeTrigger::StatusValueTimestamp,
        deadband_type: 0,
        deadband_value: 0.0,
    });
    let items: Vec<MonitoredItemCreateRequest> = nodes
        .iter()
        .enumerate()
        .map(|(k, id)| MonitoredItemCreateRequest {
            item_to_monitor: ReadValueId::from(id.clone()),
            monitoring_mode: MonitoringMode::Reporting,
            requested_parameters: MonitoringParameters {
                client_handle: k as u32 + 1,
                sampling_interval: 0.0,
                filter: filter.clone(),
                queue_size: QUEUE,
                discard_oldest: false,
            },
        })
        .collect();
    let made = session
        .create_monitored_items(id, TimestampsToReturn::Both, items)
        .await
        .map_err(|e| format!("cannot monitor the nodes: {e}"))?;
    let refused: Vec<String> = made
        .iter()
        .zip(nodes)
        .filter(|(r, _)| !r.result.status_code.is_good())
        .map(|(r, id)| format!("{id}: {}", r.result.status_code))
        .collect();
    match refused.is_empty() {
        true => Ok(()),
        false => Err(format!(
            "the server refused to monitor {}",
            refused.join(", ")
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values of two nodes arrive interleaved and split across looks: a row is handed on once
    /// both nodes have passed its time, in time order, on the build's clock; a value sent again
    /// after a reconnection is counted and not fed; a node reads its probe's place in the row.
    #[test]
    fn rows_are_whole_in_time_order_and_repeats_are_counted() {
        let (tx, rx) = mpsc::channel();
        let origin = 1_000_000_000;
        let mut sub = Subscription::on(rx, origin, vec![2, 0], 3);
        let at = |t: f64| origin + (t * 1e7) as i64;
        let value = |node, t, value| Event::Value {
            node,
            ticks: at(t),
            value,
        };
        tx.send(value(0, 1.0, 10.0)).unwrap();
        tx.send(value(0, 2.0, 11.0)).unwrap();
        tx.send(value(1, 1.0, 20.0)).unwrap();
        let (rows, said) = sub.look().unwrap();
        assert!(said.is_empty());
        assert_eq!(rows, vec![(1.0, vec![Some(20.0), None, Some(10.0)])]);
        tx.send(Event::Lost("BadCommunicationError".into()))
            .unwrap();
        tx.send(Event::Reconnected).unwrap();
        tx.send(value(1, 1.0, 20.0)).unwrap();
        tx.send(value(1, 2.0, 21.0)).unwrap();
        tx.send(value(0, 2.0, 11.0)).unwrap();
        let (rows, said) = sub.look().unwrap();
        assert_eq!(said.len(), 2);
        assert_eq!(rows, vec![(2.0, vec![Some(21.0), None, Some(11.0)])]);
        assert_eq!(sub.counts.repeated, 2);
        assert_eq!(sub.counts.reconnects, 1);
        // A resumed run's rows up to its last fed are never handed on again.
        sub.after(Some(3.0));
        tx.send(value(0, 3.0, 12.0)).unwrap();
        tx.send(value(1, 3.0, 22.0)).unwrap();
        assert!(sub.look().unwrap().0.is_empty());
        assert_eq!(sub.counts.repeated, 4);
    }
}
