//! A plain Zenoh peer speaking rmw_zenoh_cpp's topic conventions, using
//! nothing but `zenoh` and the standard library, so that the same file builds
//! against any Zenoh 1.x line: here with the workspace's, and in
//! `tests/zenoh-lines/<line>/` pinned to Zenoh 1.8.0 (what every rmw_zenoh_cpp
//! release ships) and 1.10.2 (whose shared memory differs). Its own CDR writer
//! and reader of `sensor_msgs/msg/Image`, its own 33-byte attachment: it
//! checks our bytes rather than trusting our code.
//!
//! ```text
//! zenoh_peer sub <connect> <key> <token template> <count> <data bytes> <timeout s>
//! zenoh_peer pub <connect> <key> <token template> <count> <data bytes>
//! zenoh_peer echo <connect> <key> <token template> <count> <data bytes> <timeout s> <pong key>
//! ```
//!
//! `{zid}` in the token template is replaced by the peer's Zenoh session id: the
//! liveliness token an rmw_zenoh_cpp endpoint declares, so that the other
//! side's graph sees this one. Each mode prints one JSON line: `sub` how many
//! images arrived, how many in shared memory (`ZBytes::as_shm`), how many
//! byte-exact; `pub` how many it wrote into its shared-memory pool. `echo`
//! (the latency benchmark `zenoh_lines`) checks each image in place, as it
//! arrived, and answers at once on the pong key with 6 bytes: the image's
//! sequence number (u32 LE), whether it arrived in shared memory, whether it
//! was exact.

use std::time::{Duration, Instant};

use zenoh::bytes::ZBytes;
use zenoh::shm::{BlockOn, GarbageCollect, ShmProviderBuilder};
use zenoh::{Config, Wait};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error + Send + Sync>>;

/// The pool: room for a few 8 MiB images in flight.
const POOL: usize = 64 << 20;
const FRAME_ID: &str = "peer";
const ENCODING: &str = "mono8";

fn config(connect: &str) -> Result<Config> {
    let mut config = Config::default();
    config.insert_json5("mode", r#""peer""#)?;
    config.insert_json5("scouting/multicast/enabled", "false")?;
    config.insert_json5("connect/endpoints", &format!(r#"["{connect}"]"#))?;
    config.insert_json5("transport/shared_memory/enabled", "true")?;
    Ok(config)
}

/// The value every image carries at `i` of its data, for image `seq`.
fn pixel(seq: u32, i: usize) -> u8 {
    (i as u32).wrapping_mul(31).wrapping_add(seq) as u8
}

fn align(pos: usize, to: usize) -> usize {
    pos.div_ceil(to) * to
}

/// The encoded size of an image with `data` bytes: encapsulation, stamp,
/// frame_id, height, width, encoding, is_bigendian, step, data.
fn image_len(data: usize) -> usize {
    let mut pos = 4 + 8;
    pos = align(pos, 4) + 4 + FRAME_ID.len() + 1;
    pos = align(pos, 4) + 8;
    pos = align(pos, 4) + 4 + ENCODING.len() + 1;
    pos += 1;
    pos = align(pos, 4) + 4;
    pos = align(pos, 4) + 4;
    pos + data
}

/// Little-endian CDR of image `seq` into `out` (exactly `image_len` bytes),
/// offsets counted after the 4-byte encapsulation header.
fn write_image(out: &mut [u8], seq: u32, data: usize) {
    let start = write_header(out, seq, data);
    for (i, byte) in out[start..start + data].iter_mut().enumerate() {
        *byte = pixel(seq, i);
    }
}

/// Everything of image `seq` before its pixels; returns where they start.
fn write_header(out: &mut [u8], seq: u32, data: usize) -> usize {
    out[..4].copy_from_slice(&[0, 1, 0, 0]);
    let mut pos = 0;
    let mut put = |bytes: &[u8], align_to: usize, pos: &mut usize| {
        let at = 4 + align(*pos, align_to);
        out[4 + *pos..at].fill(0);
        out[at..at + bytes.len()].copy_from_slice(bytes);
        *pos = at - 4 + bytes.len();
    };
    put(&(seq as i32).to_le_bytes(), 4, &mut pos);
    put(&0u32.to_le_bytes(), 4, &mut pos);
    put(&(FRAME_ID.len() as u32 + 1).to_le_bytes(), 4, &mut pos);
    put(FRAME_ID.as_bytes(), 1, &mut pos);
    put(&[0], 1, &mut pos);
    put(&1u32.to_le_bytes(), 4, &mut pos);
    put(&(data as u32).to_le_bytes(), 4, &mut pos);
    put(&(ENCODING.len() as u32 + 1).to_le_bytes(), 4, &mut pos);
    put(ENCODING.as_bytes(), 1, &mut pos);
    put(&[0, 0], 1, &mut pos);
    put(&(data as u32).to_le_bytes(), 4, &mut pos);
    put(&(data as u32).to_le_bytes(), 4, &mut pos);
    4 + pos
}

/// Whether `bytes` is image `seq` of `data` bytes as `write_image` lays it out
/// (the stamp's seconds carry the sequence), read where it lies.
fn check_image(bytes: &[u8], data: usize) -> Option<u32> {
    if bytes.len() != image_len(data) || bytes.get(..2) != Some(&[0, 1][..]) {
        return None;
    }
    let seq = u32::from_le_bytes(bytes.get(4..8)?.try_into().ok()?);
    let header_len = image_len(0);
    let mut header = vec![0; header_len];
    write_header(&mut header, seq, data);
    // Bytes 2..4 are the encapsulation options, which writers may set.
    let pixels_ok = bytes[header_len..]
        .iter()
        .enumerate()
        .all(|(i, &b)| b == pixel(seq, i));
    (bytes[4..header_len] == header[4..] && pixels_ok).then_some(seq)
}

/// rmw_zenoh_cpp's attachment: sequence number, source timestamp, GID.
fn attachment(seq: i64, gid: &[u8; 16]) -> Vec<u8> {
    let mut out = Vec::with_capacity(33);
    out.extend_from_slice(&seq.to_le_bytes());
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as i64);
    out.extend_from_slice(&now.to_le_bytes());
    out.push(16);
    out.extend_from_slice(gid);
    out
}

fn attachment_ok(attachment: Option<&ZBytes>) -> bool {
    attachment.is_some_and(|a| {
        let a = a.to_bytes();
        a.len() == 33 && a[16] == 16
    })
}

fn arg<'a>(args: &'a [String], i: usize, what: &str) -> Result<&'a str> {
    args.get(i)
        .map(String::as_str)
        .ok_or_else(|| format!("missing argument {i}: {what}").into())
}

/// What every mode takes first: the session on the endpoint, the key, the
/// token (its `{zid}` filled in), the count and the image's data bytes.
struct Common<'a> {
    session: zenoh::Session,
    key: &'a str,
    token: String,
    count: usize,
    data: usize,
}

fn common(args: &[String]) -> Result<Common<'_>> {
    let session = zenoh::open(config(arg(args, 2, "connect endpoint")?)?).wait()?;
    let token = arg(args, 4, "token template")?.replace("{zid}", &session.zid().to_string());
    Ok(Common {
        key: arg(args, 3, "key expression")?,
        token,
        count: arg(args, 5, "count")?.parse()?,
        data: arg(args, 6, "data bytes")?.parse()?,
        session,
    })
}

fn subscribe(args: &[String]) -> Result<()> {
    let Common {
        session,
        key,
        token,
        count,
        data,
    } = common(args)?;
    let timeout = Duration::from_secs(arg(args, 7, "timeout")?.parse()?);
    let subscriber = session.declare_subscriber(key).wait()?;
    let _token = session.liveliness().declare_token(token).wait()?;
    println!("READY {}", session.zid());
    let (mut received, mut shm, mut exact, mut attachments) = (0, 0, 0, 0);
    let deadline = Instant::now() + timeout;
    while received < count {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(Some(sample)) = subscriber.recv_timeout(left) else {
            break;
        };
        received += 1;
        shm += usize::from(sample.payload().as_shm().is_some());
        exact += usize::from(check_image(&sample.payload().to_bytes(), data).is_some());
        attachments += usize::from(attachment_ok(sample.attachment()));
    }
    println!(
        r#"{{"received": {received}, "shm": {shm}, "exact": {exact}, "attachments": {attachments}}}"#
    );
    session.close().wait()?;
    Ok(())
}

fn echo(args: &[String]) -> Result<()> {
    let Common {
        session,
        key,
        token,
        count,
        data,
    } = common(args)?;
    let timeout = Duration::from_secs(arg(args, 7, "timeout")?.parse()?);
    let pongs = session
        .declare_publisher(arg(args, 8, "pong key")?.to_owned())
        .wait()?;
    let subscriber = session.declare_subscriber(key).wait()?;
    let _token = session.liveliness().declare_token(token).wait()?;
    println!("READY {}", session.zid());
    let deadline = Instant::now() + timeout;
    for _ in 0..count {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(Some(sample)) = subscriber.recv_timeout(left) else {
            break;
        };
        let payload = sample.payload();
        let shm = payload.as_shm();
        let checked = match shm {
            Some(shm) => check_image(shm, data),
            None => check_image(&payload.to_bytes(), data),
        };
        let mut pong = checked.unwrap_or(u32::MAX).to_le_bytes().to_vec();
        pong.push(u8::from(shm.is_some()));
        pong.push(u8::from(checked.is_some()));
        pongs.put(pong).wait()?;
    }
    session.close().wait()?;
    Ok(())
}

fn publish(args: &[String]) -> Result<()> {
    let Common {
        session,
        key,
        token,
        count,
        data,
    } = common(args)?;
    let count = u32::try_from(count)?;
    let provider = ShmProviderBuilder::default_backend(POOL).wait()?;
    // Blocking, as rmw_zenoh_cpp's reliable KEEP_ALL publishers: an 8 MiB
    // image copied into a link without shared memory can fill the queue, and
    // Zenoh's default (drop) would lose it.
    let publisher = session
        .declare_publisher(key.to_owned())
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .wait()?;
    let _token = session.liveliness().declare_token(token).wait()?;
    let deadline = Instant::now() + Duration::from_secs(10);
    while !publisher.matching_status().wait()?.matching() {
        if Instant::now() > deadline {
            return Err("no subscriber matched within 10 s".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let gid = *b"zenoh-peer-gid!!";
    let len = image_len(data);
    let mut in_shm = 0;
    for seq in 0..count {
        let mut buffer = provider
            .alloc(len)
            .with_policy::<BlockOn<GarbageCollect>>()
            .wait()?;
        write_image(&mut buffer, seq, data);
        in_shm += 1;
        publisher
            .put(buffer)
            .attachment(attachment(i64::from(seq) + 1, &gid))
            .wait()?;
        std::thread::sleep(Duration::from_millis(5));
    }
    println!(r#"{{"published": {count}, "shm": {in_shm}}}"#);
    // Let the last images leave before the session closes.
    std::thread::sleep(Duration::from_millis(500));
    session.close().wait()?;
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("sub") => subscribe(&args),
        Some("pub") => publish(&args),
        Some("echo") => echo(&args),
        _ => Err("usage: zenoh_peer sub|pub|echo <connect> <key> <token template> <count> <data bytes> [timeout s] [pong key]".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_reads_back() {
        let mut bytes = vec![0; image_len(1000)];
        write_image(&mut bytes, 7, 1000);
        assert_eq!(check_image(&bytes, 1000), Some(7));
        bytes[200] ^= 1;
        assert_eq!(check_image(&bytes, 1000), None);
    }
}
