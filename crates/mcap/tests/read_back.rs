//! A tracked run written as MCAP reads back with the `mcap` crate: the standard ROS 2
//! schemas on the expected topics, one message per frame, and messages that decode to the
//! records' figures (in metres).

use std::collections::BTreeMap;

use flexshape_lab::demo::Demo;
use flexshape_mcap::{Compression, ImageFormat, McapOptions, McapSink};
use flexshape_model::{ManipulatorParams, Model};
use flexshape_record::TrackRecord;
use flexshape_sim::SimConfig;

/// Reads CDR fields back in order (little-endian, aligned from the end of the header).
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn align(&mut self, n: usize) {
        while !(self.at - 4).is_multiple_of(n) {
            self.at += 1;
        }
    }
    fn u32(&mut self) -> u32 {
        self.align(4);
        self.at += 4;
        u32::from_le_bytes(self.b[self.at - 4..self.at].try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        self.align(8);
        self.at += 8;
        f64::from_le_bytes(self.b[self.at - 8..self.at].try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let n = self.u32() as usize;
        self.at += n;
        String::from_utf8(self.b[self.at - n..self.at - 1].to_vec()).unwrap()
    }
    /// A std_msgs/Header: (seconds, nanoseconds, frame id).
    fn header(&mut self) -> (u32, u32, String) {
        (self.u32(), self.u32(), self.string())
    }
}

/// One message read back: schema name, schema encoding, data, log time.
type Message = (String, String, Vec<u8>, u64);

/// Three frames of the demo tracked and written with `images`: the records, each topic's
/// messages, each topic's channel metadata, and the rig's cameras.
struct Written {
    records: Vec<TrackRecord>,
    by_topic: BTreeMap<String, Vec<Message>>,
    metadata: BTreeMap<String, BTreeMap<String, String>>,
    cameras: Vec<(String, flexshape_camera::Camera)>,
    path: std::path::PathBuf,
    _dir: tempfile::TempDir,
}

fn written(images: ImageFormat, compression: Compression) -> Written {
    let model = Model::new(ManipulatorParams::paper_like()).unwrap();
    let demo = Demo::new(SimConfig::default(), model, None, 1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let rig = demo.simulator().rig();
    let cameras: Vec<_> = rig
        .cameras
        .iter()
        .map(|c| (c.name.clone(), c.camera.clone()))
        .collect();
    let options = McapOptions {
        images,
        compression,
        overwrite: false,
    };
    let mut sink = McapSink::create(&path, rig, options).unwrap();
    let mut records = Vec::new();
    for (record, p) in demo.tracked(3) {
        sink.write(&record, &p).unwrap();
        records.push(record);
    }
    sink.finish().unwrap();
    assert_eq!(records.len(), 3);
    assert!(records.iter().all(|r| r.status.as_str() == "ok"));

    let bytes = std::fs::read(&path).unwrap();
    let mut by_topic: BTreeMap<String, Vec<Message>> = BTreeMap::new();
    let mut metadata = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap();
        metadata.insert(m.channel.topic.clone(), m.channel.metadata.clone());
        by_topic.entry(m.channel.topic.clone()).or_default().push((
            schema.name.clone(),
            schema.encoding.clone(),
            m.data.to_vec(),
            m.log_time,
        ));
    }
    Written {
        records,
        by_topic,
        metadata,
        cameras,
        path,
        _dir: dir,
    }
}

#[test]
fn a_tracked_run_reads_back_with_standard_schemas() {
    let Written {
        records,
        by_topic,
        metadata,
        cameras,
        path,
        _dir,
    } = written(ImageFormat::Raw, Compression::Zstd);
    let expect = [
        ("/flexshape/centerline", "nav_msgs/msg/Path", 3),
        ("/flexshape/tube", "visualization_msgs/msg/MarkerArray", 3),
        ("/flexshape/hull", "sensor_msgs/msg/PointCloud2", 3),
        ("/tf_static", "tf2_msgs/msg/TFMessage", 1),
        (
            "/flexshape/cam0/camera_info",
            "sensor_msgs/msg/CameraInfo",
            3,
        ),
        ("/flexshape/cam2/image", "sensor_msgs/msg/Image", 3),
        ("/flexshape/cam1/silhouette", "sensor_msgs/msg/Image", 3),
        ("/flexshape/record", "flexshape.TrackRecord", 3),
    ];
    for (topic, schema, count) in expect {
        let got = by_topic
            .get(topic)
            .unwrap_or_else(|| panic!("no {topic}: {:?}", by_topic.keys()));
        assert_eq!(got.len(), count, "{topic}");
        assert_eq!(got[0].0, schema, "{topic}");
        let encoding = if topic == "/flexshape/record" {
            "jsonschema"
        } else {
            "ros2msg"
        };
        assert_eq!(got[0].1, encoding, "{topic}");
    }

    // The centerline decodes to the record's, in metres, at the record's time.
    let (_, _, data, log_time) = &by_topic["/flexshape/centerline"][1];
    let record = &records[1];
    let mut r = Reader { b: data, at: 4 };
    let (sec, nsec, frame_id) = r.header();
    assert_eq!(frame_id, "world");
    assert_eq!(u64::from(sec) * 1_000_000_000 + u64::from(nsec), *log_time);
    let n = r.u32() as usize;
    assert_eq!(n, record.centerline.len());
    for k in 0..n {
        r.header();
        let p = [r.f64(), r.f64(), r.f64()];
        let q = [r.f64(), r.f64(), r.f64(), r.f64()];
        for (got, want) in p.iter().zip(record.centerline[k]) {
            assert!((got * 1e3 - want).abs() < 1e-9);
        }
        assert!((q.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-9);
    }
    assert_eq!(r.at, data.len(), "the whole message was read");

    // The markers begin by deleting the last frame's, then add the tube.
    let (_, _, data, _) = &by_topic["/flexshape/tube"][1];
    let mut r = Reader { b: data, at: 4 };
    assert!(r.u32() >= 2, "delete-all and the tube at least");
    r.header();
    assert_eq!(r.string(), "");
    let (_id, _kind, action) = (r.u32(), r.u32(), r.u32());
    assert_eq!(action, 3, "DELETEALL first");

    // The camera info holds the rig's intrinsics.
    let (_, _, data, _) = &by_topic["/flexshape/cam0/camera_info"][0];
    let mut r = Reader { b: data, at: 4 };
    assert_eq!(r.header().2, "cam0");
    let k = &cameras[0].1.intrinsics;
    assert_eq!((r.u32(), r.u32()), (k.height, k.width));
    assert_eq!(r.string(), "plumb_bob");
    let d: Vec<f64> = (0..r.u32()).map(|_| r.f64()).collect();
    assert_eq!(d, k.distortion.to_opencv());
    let kk: Vec<f64> = (0..9).map(|_| r.f64()).collect();
    assert_eq!([kk[0], kk[2], kk[4], kk[5]], [k.fx, k.cx, k.fy, k.cy]);

    // The silhouette is a mono8 image of the camera's size with the object in it.
    let (_, _, data, _) = &by_topic["/flexshape/cam1/silhouette"][0];
    let mut r = Reader { b: data, at: 4 };
    assert_eq!(r.header().2, "cam1");
    let k = &cameras[1].1.intrinsics;
    assert_eq!((r.u32(), r.u32()), (k.height, k.width));
    assert_eq!(r.string(), "mono8");
    r.at += 1; // is_bigendian
    assert_eq!(r.u32(), k.width);
    let n = r.u32() as usize;
    assert_eq!(n, (k.width * k.height) as usize);
    let object = data[r.at..r.at + n].iter().filter(|&&v| v == 255).count();
    assert!(object > 1000 && object < n / 10, "{object} object pixels");

    // The record channel's schema is the record's JSON Schema; the channel holds the record.
    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let record_schema = summary
        .schemas
        .values()
        .find(|s| s.name == "flexshape.TrackRecord")
        .unwrap();
    let schema: serde_json::Value = serde_json::from_slice(&record_schema.data).unwrap();
    // Its chunks are zstd, which every MCAP reader reads.
    assert!(!summary.chunk_indexes.is_empty());
    assert!(
        summary
            .chunk_indexes
            .iter()
            .all(|c| c.compression == "zstd")
    );
    assert_eq!(
        schema,
        serde_json::to_value(flexshape_record::record_schema()).unwrap()
    );
    assert!(schema["properties"]["centerline"].is_object(), "{schema}");
    // The record channel holds the JSON record itself.
    let (_, _, data, _) = &by_topic["/flexshape/record"][2];
    let json: serde_json::Value = serde_json::from_slice(data).unwrap();
    assert_eq!(json["frame"], records[2].frame);

    // The cameras' poses are latched for `ros2 bag play` (transient local), the rest not.
    let qos = &metadata["/tf_static"]["offered_qos_profiles"];
    assert!(
        qos.contains("durability: 1") && qos.contains("reliability: 1"),
        "{qos}"
    );
    assert!(metadata["/flexshape/centerline"].is_empty());

    // An existing file is not replaced unless asked.
    let model = Model::new(ManipulatorParams::paper_like()).unwrap();
    let demo = Demo::new(SimConfig::default(), model, None, 1).unwrap();
    let again = McapSink::create(&path, demo.simulator().rig(), McapOptions::default());
    assert!(again.is_err_and(|e| e.to_string().contains("--overwrite")));
}

#[test]
fn compressed_images_decode_to_the_cameras_views() {
    let w = written(ImageFormat::Jpeg, Compression::None);
    let bytes = std::fs::read(&w.path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert!(
        summary
            .chunk_indexes
            .iter()
            .all(|c| c.compression.is_empty())
    );
    // Images as JPEG, silhouettes as PNG, one each per frame and camera.
    for (name, camera) in &w.cameras {
        let k = &camera.intrinsics;
        for (kind, format) in [("image", "jpeg"), ("silhouette", "png")] {
            let got = &w.by_topic[&format!("/flexshape/{name}/{kind}")];
            assert_eq!(got.len(), 3, "{name} {kind}");
            assert_eq!(got[0].0, "sensor_msgs/msg/CompressedImage");
            let data = &got[1].2;
            let mut r = Reader { b: data, at: 4 };
            assert_eq!(r.header().2, *name);
            assert_eq!(r.string(), format);
            let n = r.u32() as usize;
            assert_eq!(r.at + n, data.len(), "the file fills the message");
            let file = &data[r.at..];
            assert!(n < 200_000, "{name} {kind}: {n} bytes");
            let img = image::load_from_memory(file).unwrap();
            assert_eq!((img.width(), img.height()), (k.width, k.height));
            if kind == "silhouette" {
                let mask = img.to_luma8();
                let object = mask.pixels().filter(|p| p.0[0] == 255).count();
                let rest = mask.pixels().filter(|p| p.0[0] == 0).count();
                assert_eq!(object + rest, mask.len(), "a lossless mask");
                assert!(object > 100, "{object} object pixels");
            }
        }
    }
    assert_eq!(w.records.len(), 3);
}
