//! hiroz 0.2.1, the peer to beat, through its own API: a context per process
//! (its own Zenoh session, same setup as ours), `create_pub` / `create_sub` of
//! its PointCloud2, `publish(&msg)` and `recv()`.

use std::any::Any;
use std::sync::Arc;

use hiroz::context::{ZContext, ZContextBuilder};
use hiroz::pubsub::ZPub;
use hiroz::shm::{ShmConfig, ShmProviderBuilder};
use hiroz::{Builder, ZBuf};
use hiroz_msgs::builtin_interfaces::Time;
use hiroz_msgs::sensor_msgs::{PointCloud2, PointField};
use hiroz_msgs::std_msgs::Header;
use zenoh::pubsub::Publisher;
use zenoh::shm::{BlockOn, GarbageCollect, PosixShmProviderBackend, ShmProvider};
use zenoh::Wait;

use crate::common::{cloud_ok, fill_byte, now_ns, stamp_sec, Path, Pong, Setup, POOL};
use crate::ours::answer;
use crate::Sender;

/// Our SHM threshold's default, so both automatic paths switch at the same size.
const THRESHOLD: usize = shm_runtime::ShmConfig::DEFAULT_THRESHOLD;

type Pub = ZPub<PointCloud2, <PointCloud2 as hiroz::msg::ZMessage>::Serdes>;

fn context(
    setup: &Setup,
    endpoint: &str,
    listen: bool,
) -> zenoh::Result<(ZContext, Arc<ShmProvider<PosixShmProviderBackend>>)> {
    let provider = Arc::new(ShmProviderBuilder::new(POOL).build()?);
    let context = ZContextBuilder::default()
        .with_zenoh_config(setup.config(endpoint, listen)?)
        .with_shm_config(ShmConfig::new(Arc::clone(&provider)).with_threshold(THRESHOLD))
        .build()?;
    Ok((context, provider))
}

fn cloud(bytes: usize, seq: u64, data: ZBuf) -> PointCloud2 {
    PointCloud2 {
        header: Header {
            stamp: Time {
                sec: stamp_sec(seq),
                nanosec: 0,
            },
            frame_id: "xproc".into(),
        },
        height: 1,
        width: (bytes / 16) as u32,
        fields: ["x", "y", "z", "intensity"]
            .iter()
            .enumerate()
            .map(|(i, name)| PointField {
                name: (*name).into(),
                offset: 4 * i as u32,
                datatype: 7,
                count: 1,
            })
            .collect(),
        is_bigendian: false,
        point_step: 16,
        row_step: bytes as u32,
        data,
        is_dense: true,
    }
}

/// The ping side: hiroz's context, two publishers and its SHM provider.
pub struct Publishers {
    _context: ZContext,
    provider: Arc<ShmProvider<PosixShmProviderBackend>>,
    automatic: Pub,
    shm: Pub,
}

impl Publishers {
    pub fn declare(setup: &Setup, endpoint: &str) -> zenoh::Result<Publishers> {
        let (context, provider) = context(setup, endpoint, true)?;
        let node = context.create_node("xproc_ping").build()?;
        Ok(Publishers {
            automatic: node
                .create_pub::<PointCloud2>(Path::HirozAutomatic.key())
                .build()?,
            shm: node
                .create_pub::<PointCloud2>(Path::HirozShm.key())
                .build()?,
            _context: context,
            provider,
        })
    }

    pub fn senders(&self) -> Vec<Box<dyn Sender + '_>> {
        vec![
            Box::new(HirozSender {
                path: Path::HirozAutomatic,
                publishers: self,
                ready: None,
            }),
            Box::new(HirozSender {
                path: Path::HirozShm,
                publishers: self,
                ready: None,
            }),
        ]
    }
}

/// Both hiroz paths build the message before the clock: a fresh `Vec` (hiroz's
/// data field is a `ZBuf`, which cannot be refilled in place) or a `ZShmMut`
/// from its provider, filled; the clock covers `publish(&msg)`.
struct HirozSender<'p> {
    path: Path,
    publishers: &'p Publishers,
    ready: Option<PointCloud2>,
}

impl Sender for HirozSender<'_> {
    fn path(&self) -> Path {
        self.path
    }

    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()> {
        let data = if self.path == Path::HirozShm {
            let mut block = self
                .publishers
                .provider
                .alloc(bytes)
                .with_policy::<BlockOn<GarbageCollect>>()
                .wait()?;
            block.fill(fill_byte(seq));
            ZBuf::from(block)
        } else {
            ZBuf::from(vec![fill_byte(seq); bytes])
        };
        self.ready = Some(cloud(bytes, seq, data));
        Ok(())
    }

    fn send(&mut self) -> zenoh::Result<()> {
        let msg = self.ready.take().ok_or("hiroz message not prepared")?;
        let publisher = if self.path == Path::HirozShm {
            &self.publishers.shm
        } else {
            &self.publishers.automatic
        };
        publisher.publish(&msg)?;
        Ok(())
    }
}

/// The echo side: hiroz's subscribers answering through our pong publisher, in
/// a callback (`build_with_callback`) or a thread each blocking in `recv()`. The
/// time is taken when hiroz hands over the decoded message.
pub fn echo(
    setup: &Setup,
    endpoint: &str,
    pong: &Arc<Publisher<'static>>,
) -> zenoh::Result<Vec<Box<dyn Any + Send>>> {
    let (context, _provider) = context(setup, endpoint, false)?;
    let node = context.create_node("xproc_echo").build()?;
    let mut alive: Vec<Box<dyn Any + Send>> = Vec::new();
    for path in [Path::HirozAutomatic, Path::HirozShm] {
        let builder = node.create_sub::<PointCloud2>(path.key());
        let pong = Arc::clone(pong);
        if setup.callback {
            alive.push(Box::new(builder.build_with_callback(move |cloud| {
                answer(&pong, reply(path, cloud))
            })?));
        } else {
            let subscriber = builder.build()?;
            alive.push(Box::new(std::thread::spawn(move || {
                while let Ok(cloud) = subscriber.recv() {
                    answer(&pong, reply(path, cloud));
                }
            })));
        }
    }
    alive.push(Box::new(node));
    alive.push(Box::new(context));
    Ok(alive)
}

fn reply(path: Path, cloud: PointCloud2) -> Pong {
    let at_ns = now_ns();
    let seq = cloud.header.stamp.sec as u64;
    let parts: Vec<&[u8]> = cloud.data.0.zslices().map(|s| s.as_slice()).collect();
    let ok = cloud_ok(&cloud.header.frame_id, cloud.row_step, &parts, seq);
    Pong {
        path: path as u8,
        ok,
        seq,
        at_ns,
    }
}
