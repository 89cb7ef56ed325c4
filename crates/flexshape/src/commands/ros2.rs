//! `--ros2`: the run published live as ROS 2 topics while it goes on.

#[cfg(not(feature = "ros2"))]
use flexshape_record::TrackRecord;
use flexshape_rig::Rig;

/// The live ROS 2 publisher of this build.
#[cfg(feature = "ros2")]
pub use flexshape_ros2::Ros2Publisher as Publisher;

/// A build without the `ros2` feature has no publisher: none can be made.
#[cfg(not(feature = "ros2"))]
pub enum Publisher {}

#[cfg(not(feature = "ros2"))]
impl Publisher {
    pub fn publish(&mut self, _: &TrackRecord, _: &Processed) {
        match *self {}
    }
    pub fn failed_writes(&self) -> u64 {
        match *self {}
    }
}

/// The publisher `--ros2 [DOMAIN]` asks for: on DOMAIN, else `ROS_DOMAIN_ID`, else 0.
pub fn start(asked: Option<Option<u16>>, rig: &Rig) -> anyhow::Result<Option<Publisher>> {
    let Some(domain) = asked else {
        return Ok(None);
    };
    let domain = match domain {
        Some(d) => d,
        None => from_environment()?,
    };
    open(domain, rig).map(Some)
}

/// `ROS_DOMAIN_ID` as ROS reads it: unset or empty is 0.
fn from_environment() -> anyhow::Result<u16> {
    match std::env::var("ROS_DOMAIN_ID") {
        Ok(v) if !v.trim().is_empty() => v.trim().parse().map_err(|_| {
            anyhow::anyhow!("ROS_DOMAIN_ID=`{v}` is not a domain id (0–232): set it to one, or give --ros2 DOMAIN")
        }),
        _ => Ok(0),
    }
}

#[cfg(feature = "ros2")]
fn open(domain: u16, rig: &Rig) -> anyhow::Result<Publisher> {
    use anyhow::Context;
    let publisher = Publisher::start(domain, rig, flexshape_ros2::LiveOptions::default())
        .context("cannot publish the run as ROS 2 topics")?;
    eprintln!(
        "ros2: publishing on domain {domain} (ros2 topic echo /flexshape/centerline; \
         ros2 topic list shows the rest)"
    );
    Ok(publisher)
}

#[cfg(not(feature = "ros2"))]
fn open(_: u16, _: &Rig) -> anyhow::Result<Publisher> {
    anyhow::bail!(
        "this flexshape was built without ROS 2 (cargo's --no-default-features): build it with the `ros2` feature for --ros2"
    )
}
