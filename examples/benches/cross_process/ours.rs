//! The publishing and receiving sides of our paths, the hand-written `to_vec` +
//! `put`, and the raw Zenoh floors (one slice, and three fragments).

use std::any::Any;
use std::sync::Arc;

use shm_cdr::loan::InPlace;
use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::sensor_msgs::{PointCloud2, PointCloud2Lens, PointCloud2Ref};
use shm_cdr::msgs::std_msgs::Header;
use shm_runtime::msgs::sensor_msgs::PointCloud2Shm;
use shm_runtime::ShmOptions;
use shm_runtime::{Loan, RosPublisher, RosSample, SessionExt, ShmBytes, ShmContext};
use zenoh::bytes::ZBytes;
use zenoh::pubsub::Publisher;
use zenoh::sample::Sample;
use zenoh::shm::ZShmMut;
use zenoh::{Session, Wait};

use crate::common::{cloud_ok, fill_byte, floor_ok, now_ns, stamp_sec, Path, Pong};
use crate::Sender;

fn header(seq: u64) -> Header {
    Header {
        stamp: Time {
            sec: stamp_sec(seq),
            nanosec: 0,
        },
        frame_id: "xproc".into(),
    }
}

/// The cloud of `bytes` data bytes, every one [`fill_byte`]`(seq)`.
fn vec_cloud(bytes: usize, seq: u64) -> PointCloud2 {
    PointCloud2 {
        header: header(seq),
        height: 1,
        width: (bytes / 16) as u32,
        fields: shm_cdr_examples::xyzi_fields(),
        is_bigendian: false,
        point_step: 16,
        row_step: bytes as u32,
        data: vec![fill_byte(seq); bytes],
        is_dense: true,
    }
}

/// A fresh chunk of `len` bytes from the pool, every one [`fill_byte`]`(seq)`.
fn filled_chunk(shm: &ShmContext, len: usize, seq: u64) -> zenoh::Result<ZShmMut> {
    let mut chunk = shm.alloc(len).ok_or("SHM pool exhausted")?;
    chunk.fill(fill_byte(seq));
    Ok(chunk)
}

/// The publishers of the ping process: one per path, declared once.
pub struct Publishers {
    loan: RosPublisher<PointCloud2>,
    splice: RosPublisher<PointCloud2Shm>,
    automatic: RosPublisher<PointCloud2>,
    to_vec: Publisher<'static>,
    floor: Publisher<'static>,
    fragments_floor: Publisher<'static>,
}

impl Publishers {
    pub fn declare(session: &Session, shm: &ShmContext) -> zenoh::Result<Publishers> {
        Ok(Publishers {
            loan: session
                .declare_ros_publisher(Path::Loan.key())
                .shm(shm)
                .wait()?,
            splice: session
                .declare_ros_publisher(Path::Splice.key())
                .shm(shm)
                .wait()?,
            automatic: session
                .declare_ros_publisher(Path::Automatic.key())
                .shm(shm)
                .wait()?,
            // Zenoh's defaults: what a user who serializes by hand gets.
            to_vec: session.declare_publisher(Path::ToVecPut.key()).wait()?,
            floor: session.declare_publisher(Path::Floor.key()).wait()?,
            fragments_floor: session
                .declare_publisher(Path::FloorFragments.key())
                .wait()?,
        })
    }

    pub fn senders<'p>(&'p self, shm: &'p ShmContext) -> Vec<Box<dyn Sender + 'p>> {
        vec![
            Box::new(LoanSender {
                publisher: &self.loan,
                ready: None,
            }),
            Box::new(SpliceSender {
                publisher: &self.splice,
                shm,
                ready: None,
            }),
            Box::new(VecSender {
                path: Path::Automatic,
                automatic: &self.automatic,
                to_vec: &self.to_vec,
                cloud: vec_cloud(0, 0),
            }),
            Box::new(VecSender {
                path: Path::ToVecPut,
                automatic: &self.automatic,
                to_vec: &self.to_vec,
                cloud: vec_cloud(0, 0),
            }),
            Box::new(FloorSender {
                publisher: &self.floor,
                shm,
                ready: None,
            }),
            Box::new(FragmentsFloorSender {
                publisher: &self.fragments_floor,
                shm,
                ready: None,
            }),
        ]
    }
}

/// The loan: taken and written field by field before the clock; the clock
/// covers `publish()` of the chunk as it lies.
struct LoanSender<'p> {
    publisher: &'p RosPublisher<PointCloud2>,
    ready: Option<Loan<'p, PointCloud2>>,
}

impl Sender for LoanSender<'_> {
    fn path(&self) -> Path {
        Path::Loan
    }

    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()> {
        let template = vec_cloud(0, seq);
        let lens = PointCloud2Lens {
            data: bytes,
            ..InPlace::lens(&template)
        };
        let mut loan = self.publisher.loan(lens)?;
        let cloud = loan.fields()?;
        *cloud.header.stamp.sec = stamp_sec(seq);
        cloud.header.frame_id.write(&template.header.frame_id)?;
        *cloud.height = 1;
        *cloud.width = (bytes / 16) as u32;
        cloud.fields.write_slice(&template.fields)?;
        *cloud.point_step = 16;
        *cloud.row_step = bytes as u32;
        cloud.data.fill(fill_byte(seq));
        cloud.is_dense.set(true);
        self.ready = Some(loan);
        Ok(())
    }

    fn send(&mut self) -> zenoh::Result<()> {
        let loan = self.ready.take().ok_or("loan not prepared")?;
        loan.publish().wait()?;
        Ok(())
    }
}

/// The splice: a fresh SHM data buffer per message, allocated and filled before
/// the clock (as an application producing data into SHM does).
struct SpliceSender<'p> {
    publisher: &'p RosPublisher<PointCloud2Shm>,
    shm: &'p ShmContext,
    ready: Option<PointCloud2Shm>,
}

impl Sender for SpliceSender<'_> {
    fn path(&self) -> Path {
        Path::Splice
    }

    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()> {
        let data = filled_chunk(self.shm, bytes, seq)?;
        let cloud = vec_cloud(0, seq);
        self.ready = Some(PointCloud2Shm {
            header: cloud.header,
            height: 1,
            width: (bytes / 16) as u32,
            fields: cloud.fields,
            is_bigendian: false,
            point_step: 16,
            row_step: bytes as u32,
            data: ShmBytes::from(data),
            is_dense: true,
        });
        Ok(())
    }

    fn send(&mut self) -> zenoh::Result<()> {
        let cloud = self.ready.take().ok_or("splice not prepared")?;
        self.publisher.publish(&cloud).wait()?;
        Ok(())
    }
}

/// An owned cloud with `Vec` data, updated in place before the clock; the clock
/// covers serializing it: into SHM by our publisher, or `to_vec` + `put`.
struct VecSender<'p> {
    path: Path,
    automatic: &'p RosPublisher<PointCloud2>,
    to_vec: &'p Publisher<'static>,
    cloud: PointCloud2,
}

impl Sender for VecSender<'_> {
    fn path(&self) -> Path {
        self.path
    }

    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()> {
        if self.cloud.data.len() != bytes {
            self.cloud = vec_cloud(bytes, seq);
        }
        self.cloud.header.stamp.sec = stamp_sec(seq);
        self.cloud.data.fill(fill_byte(seq));
        Ok(())
    }

    fn send(&mut self) -> zenoh::Result<()> {
        if self.path == Path::Automatic {
            self.automatic.publish(&self.cloud).wait()?;
        } else {
            self.to_vec.put(shm_cdr::to_vec(&self.cloud)?).wait()?;
        }
        Ok(())
    }
}

/// The floor: Zenoh moving a pre-filled SHM buffer of the same size.
struct FloorSender<'p> {
    publisher: &'p Publisher<'static>,
    shm: &'p ShmContext,
    ready: Option<ZShmMut>,
}

impl Sender for FloorSender<'_> {
    fn path(&self) -> Path {
        Path::Floor
    }

    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()> {
        let mut block = filled_chunk(self.shm, bytes.max(8), seq)?;
        block[..8].copy_from_slice(&seq.to_le_bytes());
        self.ready = Some(block);
        Ok(())
    }

    fn send(&mut self) -> zenoh::Result<()> {
        let block = self.ready.take().ok_or("floor not prepared")?;
        self.publisher.put(block).wait()?;
        Ok(())
    }
}

/// Zenoh's own cost of a spliced payload's shape: a raw put of a heap head as
/// long as a small cloud's metadata, a pre-filled `ZShmMut` of the data, and a
/// heap tail, read back as borrowed slices. Against [`FloorSender`] it shows
/// what three fragments cost in Zenoh; against the splice, what ours adds.
struct FragmentsFloorSender<'p> {
    publisher: &'p Publisher<'static>,
    shm: &'p ShmContext,
    ready: Option<(Vec<u8>, ZShmMut)>,
}

/// The fragments floor's head: the sequence number, then [`fill_byte`].
const FRAGMENTS_HEAD: usize = 160;
/// The fragments floor's tail (what follows `data` in a PointCloud2).
const FRAGMENTS_TAIL: usize = 4;

impl Sender for FragmentsFloorSender<'_> {
    fn path(&self) -> Path {
        Path::FloorFragments
    }

    fn prepare(&mut self, bytes: usize, seq: u64) -> zenoh::Result<()> {
        let block = filled_chunk(self.shm, bytes, seq)?;
        let mut head = vec![fill_byte(seq); FRAGMENTS_HEAD];
        head[..8].copy_from_slice(&seq.to_le_bytes());
        self.ready = Some((head, block));
        Ok(())
    }

    fn send(&mut self) -> zenoh::Result<()> {
        let (head, block) = self.ready.take().ok_or("fragments floor not prepared")?;
        let mut payload = ZBytes::writer();
        payload.append(ZBytes::from(head));
        payload.append(ZBytes::from(block));
        payload.append(ZBytes::from(vec![0u8; FRAGMENTS_TAIL]));
        self.publisher.put(payload.finish()).wait()?;
        Ok(())
    }
}

/// The echo side of our paths, the `to_vec` path and the floor, answering every
/// message with a [`Pong`]: in Zenoh's thread (`callback`) or in a thread of its
/// own per path blocking in `recv`. Returns what must stay alive.
pub fn echo(
    session: &Session,
    pong: &Arc<Publisher<'static>>,
    callback: bool,
) -> zenoh::Result<Vec<Box<dyn Any + Send>>> {
    let mut alive: Vec<Box<dyn Any + Send>> = Vec::new();
    for path in [Path::Loan, Path::Splice, Path::Automatic] {
        let builder = session.declare_ros_subscriber::<PointCloud2>(path.key());
        let pong = Arc::clone(pong);
        if callback {
            alive.push(Box::new(
                builder
                    .callback_inline(move |sample| answer(&pong, ros_reply(path, sample)))
                    .wait()?,
            ));
        } else {
            let subscriber = builder.wait()?;
            alive.push(Box::new(std::thread::spawn(move || {
                while let Ok(sample) = subscriber.recv() {
                    answer(&pong, ros_reply(path, sample));
                }
            })));
        }
    }
    for (path, reply) in [
        (Path::ToVecPut, to_vec_reply as fn(Sample) -> Pong),
        (Path::Floor, floor_reply),
        (Path::FloorFragments, fragments_floor_reply),
    ] {
        let builder = session.declare_subscriber(path.key());
        let pong = Arc::clone(pong);
        if callback {
            alive.push(Box::new(
                builder
                    .callback(move |sample| answer(&pong, reply(sample)))
                    .wait()?,
            ));
        } else {
            let subscriber = builder.wait()?;
            alive.push(Box::new(std::thread::spawn(move || {
                while let Ok(sample) = subscriber.recv() {
                    answer(&pong, reply(sample));
                }
            })));
        }
    }
    Ok(alive)
}

/// Send the pong (the sample is already released).
pub fn answer(pong: &Publisher<'static>, reply: Pong) {
    let _ = pong.put(reply.to_bytes().to_vec()).wait();
}

/// Ours: borrowed decode, the time, then the check of every byte. The sample is
/// consumed, so it is released before the pong: the ping's next chunk can
/// reuse its memory.
fn ros_reply(path: Path, sample: RosSample) -> Pong {
    let Ok(cloud) = sample.decode::<PointCloud2Ref>() else {
        return failed(path);
    };
    let at_ns = now_ns();
    let seq = cloud.header.stamp.sec as u64;
    let ok = cloud_ok(&cloud.header.frame_id, cloud.row_step, &[cloud.data], seq);
    Pong {
        path: path as u8,
        ok,
        seq,
        at_ns,
    }
}

/// `to_vec` + `put`: what a user would write by hand, an owned decode.
fn to_vec_reply(sample: Sample) -> Pong {
    let Ok(cloud) = shm_cdr::from_bytes::<PointCloud2>(&sample.payload().to_bytes()) else {
        return failed(Path::ToVecPut);
    };
    let at_ns = now_ns();
    let seq = cloud.header.stamp.sec as u64;
    let ok = cloud_ok(&cloud.header.frame_id, cloud.row_step, &[&cloud.data], seq);
    Pong {
        path: Path::ToVecPut as u8,
        ok,
        seq,
        at_ns,
    }
}

/// The floor: the payload as contiguous bytes (borrowed from the SHM chunk).
fn floor_reply(sample: Sample) -> Pong {
    let bytes = sample.payload().to_bytes();
    let at_ns = now_ns();
    match floor_ok(&bytes) {
        Some(seq) => Pong {
            path: Path::Floor as u8,
            ok: true,
            seq,
            at_ns,
        },
        None => failed(Path::Floor),
    }
}

/// The fragments floor: its three slices borrowed (the data from the SHM chunk).
fn fragments_floor_reply(sample: Sample) -> Pong {
    let payload = sample.payload();
    let mut slices = payload.slices();
    let parts = (slices.next(), slices.next(), slices.next(), slices.next());
    let at_ns = now_ns();
    let checked = match parts {
        (Some(head), Some(data), Some(tail), None) if tail.len() == FRAGMENTS_TAIL => {
            floor_ok(head).filter(|&seq| data.iter().all(|&b| b == fill_byte(seq)))
        }
        _ => None,
    };
    match checked {
        Some(seq) => Pong {
            path: Path::FloorFragments as u8,
            ok: true,
            seq,
            at_ns,
        },
        None => failed(Path::FloorFragments),
    }
}

/// The pong of a message that could not be read at all.
pub fn failed(path: Path) -> Pong {
    Pong {
        path: path as u8,
        ok: false,
        seq: u64::MAX,
        at_ns: 0,
    }
}
