//! rosbag2's sqlite3 storage (`.db3`): tables `topics` and `messages`, and
//! since Iron `message_definitions`. Each schema rosbag2 has written is
//! read: the columns a table has are looked up, not assumed. Messages are
//! read in batches ordered by (timestamp, id), through the timestamp index
//! rosbag2 creates.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use rusqlite::{Connection, OpenFlags, OptionalExtension};

use super::{BagMessage, FileStats, MessageCursor, RecordedTopic, StorageFile};
use crate::{qos, Error};

/// The most messages, and about the most bytes, read from the database at
/// once.
const BATCH_ROWS: usize = 256;
const BATCH_BYTES: usize = 64 << 20;

pub(crate) struct Sqlite3File {
    path: PathBuf,
    db: Connection,
}

impl Sqlite3File {
    pub(crate) fn open(path: &Path) -> Result<Self, Error> {
        let db = open(path)?;
        let tables: Vec<String> = query(
            path,
            &db,
            "SELECT name FROM sqlite_master WHERE type = 'table'",
            [],
            |r| r.get(0),
        )?;
        for needed in ["topics", "messages"] {
            if !tables.iter().any(|t| t == needed) {
                return Err(format!(
                    "{}: a SQLite database without rosbag2's `{needed}` table",
                    path.display()
                )
                .into());
            }
        }
        Ok(Self {
            path: path.to_owned(),
            db,
        })
    }

    fn columns(&self, table: &str) -> Result<Vec<String>, Error> {
        query(
            &self.path,
            &self.db,
            &format!("PRAGMA table_info({table})"),
            [],
            |r| r.get(1),
        )
    }

    /// Topic id → name and type.
    fn topic_names(&self) -> Result<HashMap<i64, (String, String)>, Error> {
        Ok(query(
            &self.path,
            &self.db,
            "SELECT id, name, type FROM topics",
            [],
            |r| Ok((r.get(0)?, (r.get(1)?, r.get(2)?))),
        )?
        .into_iter()
        .collect())
    }
}

fn open(path: &Path) -> Result<Connection, Error> {
    Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| format!("cannot open {} as SQLite: {e}", path.display()).into())
}

fn query<T, P: rusqlite::Params>(
    path: &Path,
    db: &Connection,
    sql: &str,
    params: P,
    row: impl FnMut(&rusqlite::Row<'_>) -> rusqlite::Result<T>,
) -> Result<Vec<T>, Error> {
    let bad = |e: rusqlite::Error| format!("{}: {e}", path.display());
    let mut statement = db.prepare(sql).map_err(bad)?;
    let rows = statement.query_map(params, row).map_err(bad)?;
    rows.collect::<Result<Vec<T>, _>>()
        .map_err(|e| bad(e).into())
}

/// A time as rosbag2 stores it (an SQLite integer) as this crate keeps it.
fn time(path: &Path, t: i64) -> Result<u64, Error> {
    u64::try_from(t)
        .map_err(|_| format!("{}: a message time of {t} ns, before 1970", path.display()).into())
}

impl StorageFile for Sqlite3File {
    fn topics(&self) -> Result<Vec<RecordedTopic>, Error> {
        let columns = self.columns("topics")?;
        let has = |c: &str| columns.iter().any(|x| x == c);
        // Foxy added the QoS profiles, Iron the type hash.
        let sql = format!(
            "SELECT id, name, type, serialization_format, {}, {} FROM topics ORDER BY id",
            if has("offered_qos_profiles") {
                "offered_qos_profiles"
            } else {
                "''"
            },
            if has("type_description_hash") {
                "type_description_hash"
            } else {
                "''"
            },
        );
        let counts: HashMap<i64, i64> = query(
            &self.path,
            &self.db,
            "SELECT topic_id, COUNT(*) FROM messages GROUP BY topic_id",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )?
        .into_iter()
        .collect();
        let rows: Vec<(i64, String, String, String, String, String)> =
            query(&self.path, &self.db, &sql, [], |r| {
                Ok((
                    r.get(0)?,
                    r.get(1)?,
                    r.get(2)?,
                    r.get(3)?,
                    r.get(4)?,
                    r.get(5)?,
                ))
            })?;
        Ok(rows
            .into_iter()
            .map(
                |(id, name, type_name, encoding, qos_text, hash)| RecordedTopic {
                    name,
                    type_name,
                    type_hash: hash,
                    offered_qos: qos::from_yaml(&qos_text)
                        .unwrap_or_default()
                        .iter()
                        .map(qos::QosProfile::to_qos)
                        .collect(),
                    message_encoding: encoding,
                    message_count: counts
                        .get(&id)
                        .and_then(|&c| u64::try_from(c).ok())
                        .unwrap_or(0),
                },
            )
            .collect())
    }

    fn stats(&self) -> Result<FileStats, Error> {
        let (start, end, count): (Option<i64>, Option<i64>, i64) = self
            .db
            .query_row(
                "SELECT MIN(timestamp), MAX(timestamp), COUNT(*) FROM messages",
                [],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
            )
            .map_err(|e| format!("{}: {e}", self.path.display()))?;
        match (start, end) {
            (Some(start), Some(end)) if count > 0 => Ok(FileStats {
                start: time(&self.path, start)?,
                end: time(&self.path, end)?,
                count: u64::try_from(count).unwrap_or(0),
            }),
            _ => Ok(FileStats::default()),
        }
    }

    fn largest_message(&self) -> Result<u64, Error> {
        let largest: Option<i64> = self
            .db
            .query_row("SELECT MAX(length(data)) FROM messages", [], |r| r.get(0))
            .map_err(|e| format!("{}: {e}", self.path.display()))?;
        Ok(largest.and_then(|l| u64::try_from(l).ok()).unwrap_or(0))
    }

    fn definitions(&self) -> Result<BTreeMap<String, String>, Error> {
        let has_table = self
            .db
            .query_row(
                "SELECT name FROM sqlite_master WHERE type = 'table' AND name = 'message_definitions'",
                [],
                |r| r.get::<_, String>(0),
            )
            .optional()
            .map_err(|e| format!("{}: {e}", self.path.display()))?
            .is_some();
        if !has_table {
            return Ok(BTreeMap::new());
        }
        Ok(query(
            &self.path,
            &self.db,
            "SELECT topic_type, encoded_message_definition FROM message_definitions \
             WHERE encoding = 'ros2msg' ORDER BY id",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )?
        .into_iter()
        .collect())
    }

    fn messages(&self, from: u64) -> Result<Box<dyn MessageCursor>, Error> {
        let mut cursor = Sqlite3Messages {
            path: self.path.clone(),
            db: open(&self.path)?,
            topics: self
                .topic_names()?
                .into_iter()
                .map(|(id, (name, type_name))| (id, (Rc::from(name), Rc::from(type_name))))
                .collect(),
            after: (i64::try_from(from).unwrap_or(i64::MAX), None),
            batch: VecDeque::new(),
            done: false,
        };
        cursor.fill()?;
        Ok(Box::new(cursor))
    }
}

/// A topic's name and type.
type TopicAndType = (Rc<str>, Rc<str>);

struct Sqlite3Messages {
    path: PathBuf,
    db: Connection,
    /// Topic id → name and type.
    topics: HashMap<i64, TopicAndType>,
    /// The (timestamp, id) the next batch starts after (the id `None` for
    /// the first: at the timestamp, inclusive).
    after: (i64, Option<i64>),
    batch: VecDeque<(TopicAndType, u64, Vec<u8>)>,
    done: bool,
}

impl Sqlite3Messages {
    fn fill(&mut self) -> Result<(), Error> {
        while self.batch.is_empty() && !self.done {
            let bad = |e: rusqlite::Error| format!("{}: {e}", self.path.display());
            let (after, id) = self.after;
            let sql = "SELECT id, topic_id, timestamp, data FROM messages \
                       WHERE timestamp > ?1 OR (timestamp = ?1 AND id > ?2) \
                       ORDER BY timestamp, id LIMIT ?3";
            let mut statement = self.db.prepare(sql).map_err(bad)?;
            let mut rows = statement
                .query(rusqlite::params![
                    after,
                    id.unwrap_or(i64::MIN),
                    BATCH_ROWS as i64
                ])
                .map_err(bad)?;
            let (mut read, mut bytes) = (0, 0);
            while let Some(row) = rows.next().map_err(bad)? {
                read += 1;
                let id: i64 = row.get(0).map_err(bad)?;
                let topic: i64 = row.get(1).map_err(bad)?;
                let timestamp: i64 = row.get(2).map_err(bad)?;
                self.after = (timestamp, Some(id));
                let Some((name, type_name)) = self.topics.get(&topic) else {
                    continue;
                };
                let data: Vec<u8> = row.get(3).map_err(bad)?;
                bytes += data.len();
                self.batch.push_back((
                    (Rc::clone(name), Rc::clone(type_name)),
                    time(&self.path, timestamp)?,
                    data,
                ));
                if bytes >= BATCH_BYTES {
                    break;
                }
            }
            if read == 0 {
                self.done = true;
            }
        }
        Ok(())
    }
}

impl MessageCursor for Sqlite3Messages {
    fn current(&self) -> Option<BagMessage<'_>> {
        let ((topic, type_name), log_time, data) = self.batch.front()?;
        Some(BagMessage {
            topic,
            type_name,
            log_time: *log_time,
            publish_time: *log_time,
            sequence: 0,
            data,
        })
    }

    fn advance(&mut self) -> Result<(), Error> {
        self.batch.pop_front();
        self.fill()
    }
}
