//! Joint logs from ROS bags: the `sensor_msgs/JointState` messages of one topic of an MCAP file
//! (ROS 2 bags, `cdr`; ROS 1 bags converted to MCAP, `ros1`), one row per message.
//!
//! ```no_run
//! use kinechain::io::bag::{JointStateOptions, read_joint_states};
//! let log = read_joint_states("run.mcap".as_ref(), &JointStateOptions::new("/joint_states"))?;
//! for (i, t) in log.time.iter().enumerate() {
//!     println!("{t} ns: {:?}", log.position_row(i));
//! }
//! # Ok::<(), kinechain::io::bag::BagError>(())
//! ```
//!
//! A `JointState` message names the joints it carries (drivers publish subsets, in any order,
//! sometimes from several publishers on one topic). The log has one column per joint name met in
//! the topic, in the order first met; a message that does not carry a joint leaves its entry to
//! [`Missing`]: the last value carried forward, or not a number. Entries no message has given yet
//! are not a number (NaN) either way.
//!
//! The file is read from start to end, a block at a time (bags larger than memory are fine;
//! the log's rows are kept), chunks decompressed (zstd, lz4) and their CRCs checked as they are
//! read. A file cut off in the middle of a record (a recording that was killed) is an error
//! naming the messages read, or with [`JointStateOptions::keep_truncated`] the messages before
//! the cut.

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// The topic ROS drivers publish joint states on.
pub const DEFAULT_TOPIC: &str = "/joint_states";

/// Largest record accepted (a chunk, decompressed or not): rosbag2 writes chunks of a few MiB.
const MAX_RECORD_BYTES: usize = 1 << 30;

/// Bytes read from the file at a time.
const READ_BLOCK: usize = 1 << 20;

/// Which time each row carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TimeSource {
    /// The message's `header.stamp` (when the driver sampled the joints), in ns.
    #[default]
    Header,
    /// The time the recorder logged the message (MCAP's `log_time`), in ns.
    Log,
}

/// What a row holds for a joint its message does not carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Missing {
    /// The joint's last value on the topic (NaN before the first).
    #[default]
    Hold,
    /// NaN.
    Null,
}

/// How [`read_joint_states`] reads a bag.
#[derive(Clone, Debug)]
pub struct JointStateOptions {
    /// The topic (every channel of that name; several publishers are several channels).
    pub topic: String,
    /// Which time each row carries.
    pub time: TimeSource,
    /// What a row holds for a joint its message does not carry.
    pub missing: Missing,
    /// Read the messages' `velocity` arrays into [`JointStates::velocity`].
    pub velocities: bool,
    /// Read the messages' `effort` arrays into [`JointStates::effort`].
    pub efforts: bool,
    /// A file cut off in the middle of a record gives the messages before the cut (and
    /// [`JointStates::truncated`]) instead of an error.
    pub keep_truncated: bool,
}

impl JointStateOptions {
    /// Positions of `topic`, stamped by their headers, last values carried forward.
    #[must_use]
    pub fn new(topic: &str) -> Self {
        JointStateOptions {
            topic: topic.to_string(),
            time: TimeSource::Header,
            missing: Missing::Hold,
            velocities: false,
            efforts: false,
            keep_truncated: false,
        }
    }
}

impl Default for JointStateOptions {
    fn default() -> Self {
        JointStateOptions::new(DEFAULT_TOPIC)
    }
}

/// The joint states of one topic: one row per message, in the order of the file.
#[derive(Clone, Debug, Default)]
pub struct JointStates {
    /// The topic read.
    pub topic: String,
    /// One column per joint name met in the topic, in the order first met.
    pub names: Vec<String>,
    /// Each message's time in ns ([`TimeSource`]).
    pub time: Vec<i64>,
    /// Positions, row-major (`time.len() × names.len()`), NaN where not known ([`Missing`]).
    pub position: Vec<f64>,
    /// Velocities, laid out as `position`; empty unless asked for.
    pub velocity: Vec<f64>,
    /// Efforts, laid out as `position`; empty unless asked for.
    pub effort: Vec<f64>,
    /// Whether the file ended in the middle of a record (only with
    /// [`JointStateOptions::keep_truncated`]; the rows are the messages before the cut).
    pub truncated: bool,
}

impl JointStates {
    /// The number of rows (messages).
    #[must_use]
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether the topic had no messages.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The log's column of each of `names` (the chain's entries of `q`, say), or the names the
    /// log lacks.
    ///
    /// # Errors
    /// The names of `names` that no message of the topic carries, in order.
    pub fn columns_of(&self, names: &[String]) -> Result<Vec<usize>, Vec<String>> {
        let found: Vec<Option<usize>> = names
            .iter()
            .map(|name| self.names.iter().position(|n| n == name))
            .collect();
        let missing: Vec<String> = names
            .iter()
            .zip(&found)
            .filter(|(_, c)| c.is_none())
            .map(|(n, _)| n.clone())
            .collect();
        if missing.is_empty() {
            Ok(found.into_iter().flatten().collect())
        } else {
            Err(missing)
        }
    }

    /// Row `i`'s positions, one per name.
    ///
    /// # Panics
    /// If `i` is not a row.
    #[must_use]
    pub fn position_row(&self, i: usize) -> &[f64] {
        let n = self.names.len();
        &self.position[i * n..(i + 1) * n]
    }
}

/// A bag that could not be read as joint states. Each names the file; those about the topic name
/// it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    /// The file could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The bag.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The file is not MCAP, or a record in it is malformed (a bad CRC, a bad chunk).
    #[error("{}: not a readable MCAP file: {message}", path.display())]
    Mcap {
        /// The bag.
        path: PathBuf,
        /// What the MCAP reader found.
        message: String,
    },
    /// The file ends in the middle of a record.
    #[error(
        "{}: the file ends in the middle of a record, after {messages} messages of topic {topic} \
         (a recording cut off; keep_truncated reads the messages before the cut)",
        path.display()
    )]
    Truncated {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Messages of the topic read before the cut.
        messages: usize,
    },
    /// No channel of the file has the topic.
    #[error("{}: no topic {topic}; the bag has {}", path.display(), list_topics(topics))]
    NoTopic {
        /// The bag.
        path: PathBuf,
        /// The topic asked for.
        topic: String,
        /// The file's topics and their message types.
        topics: Vec<(String, String)>,
    },
    /// The topic carries messages of another type (or encoding).
    #[error(
        "{}: topic {topic} carries {schema} messages ({encoding}), not sensor_msgs/msg/JointState \
         (cdr) or sensor_msgs/JointState (ros1)",
        path.display()
    )]
    WrongType {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The message type the channel declares.
        schema: String,
        /// The channel's message encoding.
        encoding: String,
    },
    /// A message of the topic does not decode as a `JointState`, or is inconsistent.
    #[error(
        "{}: message {index} of topic {topic} (log time {log_time} ns): {problem}",
        path.display()
    )]
    Message {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The message's index among the topic's messages, from 0.
        index: usize,
        /// Its log time, ns.
        log_time: u64,
        /// What is wrong with it.
        problem: String,
    },
}

fn list_topics(topics: &[(String, String)]) -> String {
    if topics.is_empty() {
        return "no topics".into();
    }
    let listed: Vec<String> = topics.iter().map(|(t, s)| format!("{t} ({s})")).collect();
    listed.join(", ")
}

/// How a channel's messages are serialised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    /// ROS 2: CDR with its 4-byte encapsulation header.
    Cdr,
    /// ROS 1 serialisation: little-endian, unaligned, strings without terminator.
    Ros1,
}

/// Reads the `JointState` messages of `options.topic` in the MCAP file at `path`.
///
/// # Errors
/// [`BagError`]: the file cannot be read or is not MCAP, is cut off (unless
/// `options.keep_truncated`), has no such topic, the topic carries another type, or a message is
/// malformed (names and positions of different lengths, a name twice, bytes missing).
pub fn read_joint_states(
    path: &Path,
    options: &JointStateOptions,
) -> Result<JointStates, BagError> {
    let io = |source| BagError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut bag = Reader::new(path, options);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(MAX_RECORD_BYTES),
    );
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = file.read(reader.insert(need.max(READ_BLOCK))).map_err(io)?;
                reader.notify_read(n);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                let record = mcap::parse_record(opcode, data).map_err(|e| bag.mcap(&e))?;
                bag.record(record)?;
            }
            Err(mcap::McapError::UnexpectedEof) if bag.seen_topic() && options.keep_truncated => {
                bag.log.truncated = true;
                break;
            }
            Err(mcap::McapError::UnexpectedEof) if bag.seen_topic() => {
                return Err(BagError::Truncated {
                    path: path.to_path_buf(),
                    topic: options.topic.clone(),
                    messages: bag.log.len(),
                });
            }
            Err(e) => return Err(bag.mcap(&e)),
        }
    }
    bag.finish()
}

/// The state of one read: the channels and schemas met, and the log being filled.
struct Reader<'a> {
    path: &'a Path,
    options: &'a JointStateOptions,
    /// Each schema's name and encoding, by id.
    schemas: HashMap<u16, (String, String)>,
    /// Every channel's topic and message type, in the order met (for errors).
    topics: Vec<(String, String)>,
    /// The channels of the topic, by id, and how their messages are serialised.
    channels: HashMap<u16, Encoding>,
    /// Each distinct list of names (its serialised bytes) met, and its entries' columns.
    layouts: HashMap<Vec<u8>, Vec<usize>>,
    /// The last value of each column (positions, velocities, efforts).
    last: [Vec<f64>; 3],
    log: JointStates,
    /// Reused: one message's names, positions, velocities, efforts.
    message: Message,
    /// The last message's serialised names and their columns: what the next message most
    /// likely has (compared byte for byte, without hashing).
    recent: (Vec<u8>, Vec<usize>),
}

#[derive(Default)]
struct Message {
    stamp: i64,
    /// Each name's text, as a byte range of the message (empty when the names are the recent
    /// ones).
    names: Vec<(usize, usize)>,
    /// The serialised list of names (its length, then its strings), as a byte range.
    names_bytes: (usize, usize),
    /// Whether the names are [`Reader::recent`]'s, recognised by their bytes and not parsed.
    recent: bool,
    values: [Vec<f64>; 3],
}

impl<'a> Reader<'a> {
    fn new(path: &'a Path, options: &'a JointStateOptions) -> Self {
        Reader {
            path,
            options,
            schemas: HashMap::new(),
            topics: Vec::new(),
            channels: HashMap::new(),
            layouts: HashMap::new(),
            last: Default::default(),
            log: JointStates {
                topic: options.topic.clone(),
                ..JointStates::default()
            },
            message: Message::default(),
            recent: (Vec::new(), Vec::new()),
        }
    }

    fn seen_topic(&self) -> bool {
        !self.channels.is_empty()
    }

    fn mcap(&self, e: &mcap::McapError) -> BagError {
        BagError::Mcap {
            path: self.path.to_path_buf(),
            message: e.to_string(),
        }
    }

    fn record(&mut self, record: Record<'_>) -> Result<(), BagError> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding));
            }
            Record::Channel(channel) => self.channel(&channel)?,
            Record::Message { header, data } => {
                if let Some(&encoding) = self.channels.get(&header.channel_id) {
                    self.message(encoding, header.log_time, &data)?;
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn channel(&mut self, channel: &mcap::records::Channel) -> Result<(), BagError> {
        let schema = self
            .schemas
            .get(&channel.schema_id)
            .map_or("(no schema)", |(name, _)| name.as_str());
        if !self.topics.iter().any(|(t, _)| *t == channel.topic) {
            self.topics
                .push((channel.topic.clone(), schema.to_string()));
        }
        if channel.topic != self.options.topic {
            return Ok(());
        }
        let encoding = match (schema, channel.message_encoding.as_str()) {
            ("sensor_msgs/msg/JointState", "cdr") => Encoding::Cdr,
            ("sensor_msgs/JointState", "ros1") => Encoding::Ros1,
            _ => {
                return Err(BagError::WrongType {
                    path: self.path.to_path_buf(),
                    topic: channel.topic.clone(),
                    schema: schema.to_string(),
                    encoding: channel.message_encoding.clone(),
                });
            }
        };
        self.channels.insert(channel.id, encoding);
        Ok(())
    }

    fn message(&mut self, encoding: Encoding, log_time: u64, data: &[u8]) -> Result<(), BagError> {
        let index = self.log.len();
        let fail = |problem: String| BagError::Message {
            path: self.path.to_path_buf(),
            topic: self.options.topic.clone(),
            index,
            log_time,
            problem,
        };
        let m = &mut self.message;
        decode(encoding, data, m, self.options, &self.recent.0).map_err(&fail)?;
        let time = match self.options.time {
            TimeSource::Header => m.stamp,
            TimeSource::Log => i64::try_from(log_time)
                .map_err(|_| fail(format!("log time {log_time} ns is past the year 2262")))?,
        };
        // Each entry's column: the last message's (drivers send the same names in every
        // message), from the layouts met before, or made now, adding new names as columns.
        if !m.recent {
            let key = &data[m.names_bytes.0..m.names_bytes.1];
            if !self.layouts.contains_key(key) {
                let mut columns = Vec::with_capacity(m.names.len());
                for &(from, to) in &m.names {
                    let name = std::str::from_utf8(&data[from..to])
                        .map_err(|_| fail("a joint name is not UTF-8".into()))?;
                    let column = match self.log.names.iter().position(|x| x == name) {
                        Some(c) => c,
                        None => {
                            self.log.names.push(name.to_string());
                            widen(&mut self.log, &mut self.last, self.options);
                            self.log.names.len() - 1
                        }
                    };
                    if columns.contains(&column) {
                        return Err(fail(format!("joint {name:?} is named twice")));
                    }
                    columns.push(column);
                }
                self.layouts.insert(key.to_vec(), columns);
            }
            self.recent.0.clear();
            self.recent.0.extend_from_slice(key);
            self.recent.1.clone_from(&self.layouts[key]);
        }
        let columns = &self.recent.1;
        let n = columns.len();
        for (k, v) in m.values.iter().enumerate() {
            if !v.is_empty() && v.len() != n {
                let what = ["position", "velocity", "effort"][k];
                return Err(fail(format!(
                    "{n} names but {} {what} values (a {what} array is empty or has one value per name)",
                    v.len()
                )));
            }
        }
        self.log.time.push(time);
        let width = self.log.names.len();
        let hold = self.options.missing == Missing::Hold;
        let outputs = [
            (&mut self.log.position, true),
            (&mut self.log.velocity, self.options.velocities),
            (&mut self.log.effort, self.options.efforts),
        ];
        for (k, (out, wanted)) in outputs.into_iter().enumerate() {
            if !wanted {
                continue;
            }
            let last = &mut self.last[k];
            for (&c, &x) in columns.iter().zip(&m.values[k]) {
                last[c] = x;
            }
            if hold {
                out.extend_from_slice(last);
            } else {
                let start = out.len();
                out.resize(start + width, f64::NAN);
                for (&c, &x) in columns.iter().zip(&m.values[k]) {
                    out[start + c] = x;
                }
            }
        }
        Ok(())
    }

    fn finish(self) -> Result<JointStates, BagError> {
        if self.channels.is_empty() {
            return Err(BagError::NoTopic {
                path: self.path.to_path_buf(),
                topic: self.options.topic.clone(),
                topics: self.topics,
            });
        }
        Ok(self.log)
    }
}

/// Adds a column (a joint met for the first time) to every row read so far.
fn widen(log: &mut JointStates, last: &mut [Vec<f64>; 3], options: &JointStateOptions) {
    let width = log.names.len();
    let rows = log.time.len();
    let outputs = [
        (&mut log.position, true),
        (&mut log.velocity, options.velocities),
        (&mut log.effort, options.efforts),
    ];
    for (v, wanted) in outputs {
        if !wanted {
            continue;
        }
        let mut wider = Vec::with_capacity(rows * width);
        for i in 0..rows {
            wider.extend_from_slice(&v[i * (width - 1)..(i + 1) * (width - 1)]);
            wider.push(f64::NAN);
        }
        *v = wider;
    }
    for l in last {
        l.push(f64::NAN);
    }
}

/// Decodes a `JointState` message into `m` (its names as byte ranges of `data`), reading the
/// velocity and effort arrays only when asked for.
fn decode(
    encoding: Encoding,
    data: &[u8],
    m: &mut Message,
    options: &JointStateOptions,
    recent: &[u8],
) -> Result<(), String> {
    let mut r = match encoding {
        Encoding::Cdr => Wire::cdr(data)?,
        Encoding::Ros1 => Wire {
            data,
            pos: 0,
            origin: 0,
            little: true,
            max_align: 1,
            strings_end_with_nul: false,
        },
    };
    // std_msgs/Header: ROS 1 starts with a sequence number; the stamp is (sec, nanosec).
    if encoding == Encoding::Ros1 {
        r.u32()?;
    }
    let sec = r.u32()?;
    let nanosec = r.u32()?;
    let sec = if encoding == Encoding::Cdr {
        i64::from(sec.cast_signed())
    } else {
        i64::from(sec)
    };
    m.stamp = sec * 1_000_000_000 + i64::from(nanosec);
    r.string()?;
    // The names, from their length on (4-aligned: the bytes alone say what they hold).
    r.align(4);
    let start = r.pos;
    m.recent = !recent.is_empty() && data.get(start..).is_some_and(|d| d.starts_with(recent));
    if m.recent {
        r.pos += recent.len();
    } else {
        let count = r.count(4)?;
        m.names.clear();
        for _ in 0..count {
            m.names.push(r.string()?);
        }
    }
    m.names_bytes = (start, r.pos);
    let wanted = [true, options.velocities, options.efforts];
    for (k, values) in m.values.iter_mut().enumerate() {
        values.clear();
        if !wanted[k] {
            // (The arrays after one not asked for are not needed either.)
            if !wanted[k..].iter().any(|&w| w) {
                break;
            }
        }
        r.f64s(values)?;
    }
    Ok(())
}

/// A reader of the serialised fields of a message.
struct Wire<'a> {
    data: &'a [u8],
    pos: usize,
    /// Where alignment is counted from (after CDR's encapsulation header).
    origin: usize,
    little: bool,
    /// The largest alignment (8 for CDR, 4 for XCDR2, 1 for ROS 1).
    max_align: usize,
    strings_end_with_nul: bool,
}

impl<'a> Wire<'a> {
    fn cdr(data: &'a [u8]) -> Result<Self, String> {
        let Some(head) = data.get(..4) else {
            return Err("shorter than a CDR encapsulation header".into());
        };
        // The encapsulation kind: CDR (XCDR1) or PLAIN_CDR2, big- or little-endian.
        let (little, max_align) = match (head[0], head[1]) {
            (0, 0) => (false, 8),
            (0, 1) => (true, 8),
            (0, 6) => (false, 4),
            (0, 7) => (true, 4),
            (a, b) => {
                return Err(format!(
                    "CDR encapsulation {a:#04x}{b:02x} is not plain CDR (XCDR1 or XCDR2)"
                ));
            }
        };
        Ok(Wire {
            data,
            pos: 4,
            origin: 4,
            little,
            max_align,
            strings_end_with_nul: true,
        })
    }

    fn align(&mut self, n: usize) {
        let a = n.min(self.max_align);
        let offset = self.pos - self.origin;
        self.pos += (a - offset % a) % a;
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        let Some(end) = end else {
            return Err(format!(
                "ends after {} bytes, inside a field that needs {n} more",
                self.data.len(),
            ));
        };
        let bytes = &self.data[self.pos..end];
        self.pos = end;
        Ok(bytes)
    }

    fn u32(&mut self) -> Result<u32, String> {
        self.align(4);
        let b: [u8; 4] = self.take(4)?.try_into().map_err(|_| String::new())?;
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    /// A sequence's length, checked against the bytes left (each element at least `size`).
    fn count(&mut self, size: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        if n.saturating_mul(size) > self.data.len() - self.pos {
            return Err(format!(
                "a sequence of {n} elements is longer than the {}-byte message",
                self.data.len()
            ));
        }
        Ok(n)
    }

    /// A string, as the byte range of its text.
    fn string(&mut self) -> Result<(usize, usize), String> {
        let n = self.count(1)?;
        let start = self.pos;
        let bytes = self.take(n)?;
        let len = if self.strings_end_with_nul {
            match bytes.split_last() {
                Some((0, _)) => n - 1,
                _ => return Err("a string without its terminating NUL".into()),
            }
        } else {
            n
        };
        Ok((start, start + len))
    }

    fn f64s(&mut self, out: &mut Vec<f64>) -> Result<(), String> {
        let n = self.count(8)?;
        // (No padding before an empty sequence's elements: there are none to align.)
        if n > 0 {
            self.align(8);
        }
        let bytes = self.take(n * 8)?;
        out.extend(bytes.chunks_exact(8).map(|b| {
            let b: [u8; 8] = [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
            if self.little {
                f64::from_le_bytes(b)
            } else {
                f64::from_be_bytes(b)
            }
        }));
        Ok(())
    }
}
