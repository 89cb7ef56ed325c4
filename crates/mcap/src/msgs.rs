//! The ROS 2 messages written, each as its `ros2msg` schema (the definition followed by those
//! of the types it uses, as `ros2 bag` records them) and a CDR encoder. Lengths in metres,
//! as ROS (REP 103) has them.

use crate::cdr::Cdr;

const SEPARATOR: &str =
    "\n================================================================================\nMSG: ";

const TIME: (&str, &str) = ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec");
const DURATION: (&str, &str) = ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec");
const HEADER: (&str, &str) = (
    "std_msgs/Header",
    "builtin_interfaces/Time stamp\nstring frame_id",
);
const COLOR: (&str, &str) = (
    "std_msgs/ColorRGBA",
    "float32 r\nfloat32 g\nfloat32 b\nfloat32 a",
);
const POINT: (&str, &str) = ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z");
const VECTOR3: (&str, &str) = ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z");
const QUATERNION: (&str, &str) = (
    "geometry_msgs/Quaternion",
    "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
);
const POSE: (&str, &str) = (
    "geometry_msgs/Pose",
    "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
);
const POSE_STAMPED: (&str, &str) = (
    "geometry_msgs/PoseStamped",
    "std_msgs/Header header\ngeometry_msgs/Pose pose",
);
const TRANSFORM: (&str, &str) = (
    "geometry_msgs/Transform",
    "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation",
);
const TRANSFORM_STAMPED: (&str, &str) = (
    "geometry_msgs/TransformStamped",
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform",
);
const POINT_FIELD: (&str, &str) = (
    "sensor_msgs/PointField",
    "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count",
);
const ROI: (&str, &str) = (
    "sensor_msgs/RegionOfInterest",
    "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify",
);
const COMPRESSED: (&str, &str) = (
    "sensor_msgs/CompressedImage",
    "std_msgs/Header header\nstring format\nuint8[] data",
);
const UV: (&str, &str) = ("visualization_msgs/UVCoordinate", "float32 u\nfloat32 v");
const MESH_FILE: (&str, &str) = (
    "visualization_msgs/MeshFile",
    "string filename\nuint8[] data",
);
const MARKER: (&str, &str) = (
    "visualization_msgs/Marker",
    "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\nstd_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\nbuiltin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\nstring texture_resource\nsensor_msgs/CompressedImage texture\nvisualization_msgs/UVCoordinate[] uv_coordinates\nstring text\nstring mesh_resource\nvisualization_msgs/MeshFile mesh_file\nbool mesh_use_embedded_materials",
);

/// A message type: its name (`package/msg/Type`) and its `ros2msg` schema text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageType {
    /// The full name, e.g. `nav_msgs/msg/Path`.
    pub name: &'static str,
    definition: &'static str,
    uses: &'static [(&'static str, &'static str)],
}

impl MessageType {
    /// The schema as MCAP's `ros2msg` encoding has it.
    pub fn schema(&self) -> String {
        let mut s = self.definition.to_string();
        for (name, text) in self.uses {
            s.push_str(SEPARATOR);
            s.push_str(name);
            s.push('\n');
            s.push_str(text);
        }
        s
    }
}

/// `nav_msgs/msg/Path`: the centerline, a pose per sample (x along the tangent).
pub const PATH: MessageType = MessageType {
    name: "nav_msgs/msg/Path",
    definition: "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses",
    uses: &[HEADER, TIME, POSE_STAMPED, POSE, POINT, QUATERNION],
};

/// `sensor_msgs/msg/PointCloud2`: the carved voxel centres.
pub const POINT_CLOUD2: MessageType = MessageType {
    name: "sensor_msgs/msg/PointCloud2",
    definition: "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense",
    uses: &[HEADER, TIME, POINT_FIELD],
};

/// `sensor_msgs/msg/CameraInfo`: a camera's intrinsics and distortion.
pub const CAMERA_INFO: MessageType = MessageType {
    name: "sensor_msgs/msg/CameraInfo",
    definition: "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi",
    uses: &[HEADER, TIME, ROI],
};

/// `sensor_msgs/msg/Image`: a camera image or silhouette.
pub const IMAGE: MessageType = MessageType {
    name: "sensor_msgs/msg/Image",
    definition: "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data",
    uses: &[HEADER, TIME],
};

/// `sensor_msgs/msg/CompressedImage`: a camera image or silhouette as a JPEG or PNG file.
pub const COMPRESSED_IMAGE: MessageType = MessageType {
    name: "sensor_msgs/msg/CompressedImage",
    definition: COMPRESSED.1,
    uses: &[HEADER, TIME],
};

/// `std_msgs/msg/String`: text (the record's JSON on ROS 2, which has no JSON encoding).
pub const STRING: MessageType = MessageType {
    name: "std_msgs/msg/String",
    definition: "string data",
    uses: &[],
};

/// `tf2_msgs/msg/TFMessage`: the cameras' poses in the world frame.
pub const TF_MESSAGE: MessageType = MessageType {
    name: "tf2_msgs/msg/TFMessage",
    definition: "geometry_msgs/TransformStamped[] transforms",
    uses: &[
        TRANSFORM_STAMPED,
        HEADER,
        TIME,
        TRANSFORM,
        VECTOR3,
        QUATERNION,
    ],
};

/// `visualization_msgs/msg/MarkerArray` (ROS 2 Humble and later): the tube, its bands and
/// tip.
pub const MARKER_ARRAY: MessageType = MessageType {
    name: "visualization_msgs/msg/MarkerArray",
    definition: "visualization_msgs/Marker[] markers",
    uses: &[
        MARKER, HEADER, TIME, POSE, POINT, QUATERNION, VECTOR3, COLOR, DURATION, COMPRESSED, UV,
        MESH_FILE,
    ],
};

/// A time stamp, nanoseconds since the Unix epoch.
pub fn header(c: &mut Cdr, stamp_ns: u64, frame_id: &str) {
    c.i32((stamp_ns / 1_000_000_000) as i32)
        .u32((stamp_ns % 1_000_000_000) as u32)
        .string(frame_id);
}

/// A `geometry_msgs/Pose`: position (m) and orientation `[x, y, z, w]`.
pub fn pose(c: &mut Cdr, p: [f64; 3], q: [f64; 4]) {
    for v in p.into_iter().chain(q) {
        c.f64(v);
    }
}

/// The `nav_msgs/Path` through `points` (m), each pose's x axis along the curve.
pub fn path(stamp_ns: u64, frame_id: &str, points: &[[f64; 3]]) -> Vec<u8> {
    let mut c = Cdr::new();
    header(&mut c, stamp_ns, frame_id);
    c.count(points.len());
    for (i, p) in points.iter().enumerate() {
        let a = points[i.saturating_sub(1)];
        let b = points[(i + 1).min(points.len() - 1)];
        header(&mut c, stamp_ns, frame_id);
        pose(
            &mut c,
            *p,
            quaternion_from_x([b[0] - a[0], b[1] - a[1], b[2] - a[2]]),
        );
    }
    c.finish()
}

/// The rotation taking the x axis to `d` (the identity for a zero `d`), `[x, y, z, w]`.
pub fn quaternion_from_x(d: [f64; 3]) -> [f64; 4] {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if n == 0.0 || !n.is_finite() {
        return [0.0, 0.0, 0.0, 1.0];
    }
    let d = [d[0] / n, d[1] / n, d[2] / n];
    // Half-way between x and d; opposite directions turn about z.
    let w = 1.0 + d[0];
    if w < 1e-12 {
        return [0.0, 0.0, 1.0, 0.0];
    }
    let q = [0.0, -d[2], d[1], w];
    let m = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    q.map(|v| v / m)
}

/// A `sensor_msgs/PointCloud2` of `points` (x, y, z float32, m), one row.
pub fn point_cloud(stamp_ns: u64, frame_id: &str, points: &[[f32; 3]]) -> Vec<u8> {
    let mut c = Cdr::new();
    header(&mut c, stamp_ns, frame_id);
    c.u32(1).u32(points.len() as u32).count(3);
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        c.string(name).u32(4 * k as u32).u8(7).u32(1);
    }
    let data: Vec<u8> = points
        .iter()
        .flat_map(|p| p.iter().flat_map(|v| v.to_le_bytes()))
        .collect();
    c.u8(0)
        .u32(12)
        .u32(12 * points.len() as u32)
        .bytes(&data)
        .u8(1);
    c.finish()
}

/// A `sensor_msgs/Image` of `data` (`encoding` as ROS names it: `rgb8`, `mono8`), rows of
/// `step` bytes.
pub fn image(
    stamp_ns: u64,
    frame_id: &str,
    size: (u32, u32),
    encoding: &str,
    step: u32,
    data: &[u8],
) -> Vec<u8> {
    let mut c = Cdr::new();
    header(&mut c, stamp_ns, frame_id);
    c.u32(size.1)
        .u32(size.0)
        .string(encoding)
        .u8(0)
        .u32(step)
        .bytes(data);
    c.finish()
}

/// A `sensor_msgs/CompressedImage` holding `data`, a whole image file in `format` (`jpeg` or
/// `png`, as ROS's image_transport and Foxglove name them).
pub fn compressed_image(stamp_ns: u64, frame_id: &str, format: &str, data: &[u8]) -> Vec<u8> {
    let mut c = Cdr::new();
    header(&mut c, stamp_ns, frame_id);
    c.string(format).bytes(data);
    c.finish()
}

/// A `std_msgs/String` holding `text`.
pub fn string(text: &str) -> Vec<u8> {
    let mut c = Cdr::new();
    c.string(text);
    c.finish()
}

/// One marker of a `MarkerArray`: `kind` (4 line strip, 2 sphere, 7 sphere list) through
/// `points` (m) in `color` (r, g, b, a), `scale` its width or diameter (m).
pub struct Marker<'a> {
    /// Its namespace.
    pub ns: &'a str,
    /// Its id within the namespace.
    pub id: i32,
    /// Its type (`visualization_msgs/Marker` constants).
    pub kind: i32,
    /// Its pose's position (m); points are relative to it.
    pub position: [f64; 3],
    /// Its scale (m).
    pub scale: [f64; 3],
    /// Its colour.
    pub color: [f32; 4],
    /// Its points (m).
    pub points: &'a [[f64; 3]],
    /// What to do with it (`visualization_msgs/Marker` constants: 0 add, 3 delete all).
    pub action: i32,
}

/// `Marker::action` that removes every marker the viewer holds (in this array's order: the
/// markers after it are added afresh).
pub const DELETE_ALL: i32 = 3;

/// A `visualization_msgs/MarkerArray` of `markers`.
pub fn marker_array(stamp_ns: u64, frame_id: &str, markers: &[Marker]) -> Vec<u8> {
    let mut c = Cdr::new();
    c.count(markers.len());
    for m in markers {
        header(&mut c, stamp_ns, frame_id);
        c.string(m.ns).i32(m.id).i32(m.kind).i32(m.action);
        pose(&mut c, m.position, [0.0, 0.0, 0.0, 1.0]);
        for v in m.scale {
            c.f64(v);
        }
        for v in m.color {
            c.f32(v);
        }
        // Lifetime 0 (forever), not frame-locked.
        c.i32(0).u32(0).u8(0);
        c.count(m.points.len());
        for p in m.points {
            c.f64(p[0]).f64(p[1]).f64(p[2]);
        }
        c.count(0); // colors
        c.string(""); // texture_resource
        header(&mut c, 0, ""); // texture: an empty CompressedImage
        c.string("").bytes(&[]);
        c.count(0); // uv_coordinates
        c.string("").string(""); // text, mesh_resource
        c.string("").bytes(&[]); // mesh_file
        c.u8(0);
    }
    c.finish()
}

/// One `geometry_msgs/TransformStamped`: `child` placed in `parent` at `translation` (m)
/// turned by `rotation` (`[x, y, z, w]`).
pub struct Transform<'a> {
    /// The parent frame.
    pub parent: &'a str,
    /// The child frame.
    pub child: &'a str,
    /// The child's origin in the parent frame, m.
    pub translation: [f64; 3],
    /// The child's axes in the parent frame.
    pub rotation: [f64; 4],
}

/// A `tf2_msgs/TFMessage` of `transforms`.
pub fn tf_message(stamp_ns: u64, transforms: &[Transform]) -> Vec<u8> {
    let mut c = Cdr::new();
    c.count(transforms.len());
    for t in transforms {
        header(&mut c, stamp_ns, t.parent);
        c.string(t.child);
        for v in t.translation.into_iter().chain(t.rotation) {
            c.f64(v);
        }
    }
    c.finish()
}

/// A `sensor_msgs/CameraInfo`: `size` (width, height), OpenCV's distortion coefficients
/// `d` (plumb bob for 5, rational polynomial for 8), `k` row-major.
pub fn camera_info(
    stamp_ns: u64,
    frame_id: &str,
    size: (u32, u32),
    d: &[f64],
    k: [f64; 9],
) -> Vec<u8> {
    let mut c = Cdr::new();
    header(&mut c, stamp_ns, frame_id);
    c.u32(size.1).u32(size.0);
    c.string(if d.len() > 5 {
        "rational_polynomial"
    } else {
        "plumb_bob"
    });
    c.count(d.len());
    for &v in d {
        c.f64(v);
    }
    for v in k {
        c.f64(v);
    }
    for v in [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
        c.f64(v);
    }
    let p = [
        k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, 0.0, 0.0, 1.0, 0.0,
    ];
    for v in p {
        c.f64(v);
    }
    c.u32(0).u32(0);
    c.u32(0).u32(0).u32(0).u32(0).u8(0);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemas_name_every_type_they_use() {
        for t in [
            PATH,
            POINT_CLOUD2,
            CAMERA_INFO,
            IMAGE,
            TF_MESSAGE,
            MARKER_ARRAY,
        ] {
            let schema = t.schema();
            // Every non-primitive field type has its definition after a separator.
            for line in schema.lines() {
                let Some(ty) = line.split_whitespace().next() else {
                    continue;
                };
                let ty = ty.trim_end_matches("[]").split('[').next().unwrap_or(ty);
                if ty.contains('/') && !line.starts_with("MSG:") {
                    assert!(
                        schema.contains(&format!("MSG: {ty}\n")),
                        "{}: {ty} has no definition",
                        t.name
                    );
                }
            }
        }
    }

    #[test]
    fn the_x_axis_turns_onto_the_direction() {
        for d in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.3, -0.2, 0.9],
            [-1.0, 0.0, 0.0],
        ] {
            let [x, y, z, w] = quaternion_from_x(d);
            let q =
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            let turned = q * nalgebra::Vector3::x();
            let n = nalgebra::Vector3::from(d).normalize();
            assert!((turned - n).norm() < 1e-12, "{d:?} → {turned}");
        }
    }
}
