//! Real cameras over V4L2/UVC (Linux) through the `nokhwa` crate.
//!
//! [`UvcCamera`] implements [`Camera`]: the station sets the exposure time itself
//! (V4L2 `auto_exposure` = manual, `exposure_time_absolute` in units of 100 µs) and
//! never lets the camera choose. Only uncompressed formats are used (RGB3, BGR3,
//! YUYV, NV12, GREY; MJPEG is lossy and its decoder is not built), at the largest
//! resolution the camera offers and the lowest frame rate there (longest exposures,
//! least USB bandwidth). V4L2 gain has no defined unit, so the gain is held at the
//! camera's lowest value, reported as unity: [`CameraInfo::gain_range`] is `[1, 1]`.
//!
//! ```no_run
//! use lumiwall_devices::Camera;
//! use lumiwall_devices::uvc::{UvcCamera, list_cameras};
//! for c in list_cameras()? {
//!     println!("{c}");
//! }
//! let mut cam = UvcCamera::open("0")?;
//! for line in cam.controls()? {
//!     println!("{line}");
//! }
//! let frame = cam.capture(0.01, 1.0)?;
//! println!("{}×{}", frame.width_px, frame.height_px);
//! # Ok::<(), lumiwall_devices::DeviceError>(())
//! ```

use std::fmt;
use std::io;
use std::time::{SystemTime, UNIX_EPOCH};

use nokhwa::pixel_format::RgbFormat;
use nokhwa::utils::{
    ApiBackend, CameraControl, CameraFormat, CameraIndex, ControlValueDescription,
    ControlValueSetter, FrameFormat, KnownCameraControl, KnownCameraControlFlag, RequestedFormat,
    RequestedFormatType,
};
use nokhwa::{Buffer, NokhwaError};

use crate::camera::MAX_FRAME_PIXELS;
use crate::{Camera, CameraInfo, DeviceError, Frame};

/// V4L2 `auto_exposure` (menu; `V4L2_CID_EXPOSURE_AUTO`).
const CID_AUTO_EXPOSURE: u32 = 0x009a_0901;
/// V4L2 `exposure_time_absolute` (100 µs units; `V4L2_CID_EXPOSURE_ABSOLUTE`).
const CID_EXPOSURE_ABSOLUTE: u32 = 0x009a_0902;
/// V4L2 `gain_automatic` (`V4L2_CID_AUTOGAIN`).
const CID_AUTOGAIN: u32 = 0x0098_0912;
/// V4L2 `gain` (`V4L2_CID_GAIN`, camera-specific units).
const CID_GAIN: u32 = 0x0098_0913;
/// `auto_exposure` menu entry for manual exposure (`V4L2_EXPOSURE_MANUAL`).
const AUTO_EXPOSURE_MANUAL: i64 = 1;
/// Unit of `exposure_time_absolute` (s).
const EXPOSURE_UNIT_S: f64 = 1e-4;
/// Frames thrown away after starting the stream, so that new settings apply.
const DISCARD_FRAMES: usize = 3;
/// Frame formats this driver decodes, best first (all uncompressed).
const FORMATS: [FrameFormat; 5] = [
    FrameFormat::RAWRGB,
    FrameFormat::RAWBGR,
    FrameFormat::YUYV,
    FrameFormat::NV12,
    FrameFormat::GRAY,
];

/// One video device as the system lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CameraListing {
    /// V4L2 index: the `N` of `/dev/videoN`.
    pub index: u32,
    /// Human-readable name (the card name, e.g. the webcam's model).
    pub name: String,
    /// Description from the backend (on Linux, the device node).
    pub description: String,
    /// Anything else the backend reports.
    pub misc: String,
}

impl fmt::Display for CameraListing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.index, self.name)?;
        if !self.description.is_empty() {
            write!(f, " ({})", self.description)?;
        }
        if !self.misc.is_empty() {
            write!(f, " [{}]", self.misc)?;
        }
        Ok(())
    }
}

/// Lists the video devices present; an empty list when there are none.
///
/// A UVC camera often appears twice (video and metadata node, same name); only
/// the video node opens, and [`UvcCamera::open`] by name picks it.
pub fn list_cameras() -> Result<Vec<CameraListing>, DeviceError> {
    let found = nokhwa::query(ApiBackend::Auto).map_err(|e| {
        io_error(
            "camera list",
            format!("cannot list the video devices: {e}; this driver needs Linux with V4L2"),
        )
    })?;
    let mut list = Vec::with_capacity(found.len());
    for c in found {
        match c.index().as_index() {
            Ok(index) => list.push(CameraListing {
                index,
                name: c.human_name(),
                description: c.description().to_string(),
                misc: c.misc(),
            }),
            Err(e) => tracing::warn!("skipping camera {}: {e}", c.human_name()),
        }
    }
    list.sort_by_key(|c| c.index);
    Ok(list)
}

/// The listed devices that `query` names: an index (`2`), a node (`/dev/video2`),
/// a name (case-insensitive), else the names containing it.
fn match_cameras<'a>(list: &'a [CameraListing], query: &str) -> Vec<&'a CameraListing> {
    let q = query.trim();
    let number = q.strip_prefix("/dev/video").unwrap_or(q);
    if let Ok(index) = number.parse::<u32>() {
        return list.iter().filter(|c| c.index == index).collect();
    }
    if q.is_empty() {
        return Vec::new();
    }
    let q = q.to_lowercase();
    let exact: Vec<_> = list
        .iter()
        .filter(|c| c.name.trim().to_lowercase() == q)
        .collect();
    if !exact.is_empty() {
        return exact;
    }
    list.iter()
        .filter(|c| c.name.to_lowercase().contains(&q))
        .collect()
}

/// [`DeviceError::NoCamera`] for `asked`, listing what exists.
fn no_camera(asked: &str, list: &[CameraListing]) -> DeviceError {
    let present = if list.is_empty() {
        "no video devices found (check the USB cable, `v4l2-ctl --list-devices`, and that \
         this user may open /dev/video*, e.g. is in group `video`)"
            .to_string()
    } else {
        let names: Vec<String> = list.iter().map(ToString::to_string).collect();
        format!("cameras present: {}", names.join("; "))
    };
    DeviceError::NoCamera(format!("no camera matches {asked:?}; {present}"))
}

/// [`DeviceError::Io`] on `device` with a message.
fn io_error(device: &str, message: String) -> DeviceError {
    DeviceError::Io {
        device: device.to_string(),
        source: io::Error::other(message),
    }
}

/// Maps a `nokhwa` error while `doing` something to a [`DeviceError`] with a hint.
fn device_error(device: &str, doing: &str, e: &NokhwaError) -> DeviceError {
    let text = e.to_string();
    let hint = match e {
        NokhwaError::OpenDeviceError(..) if text.contains("ermission") => {
            "this user may not open the device: add it to group `video` or fix the udev rules"
        }
        NokhwaError::OpenDeviceError(..) | NokhwaError::OpenStreamError(_) => {
            "the camera may be in use by another program (close it), or the USB bus lacks \
             bandwidth for this format (use another port or hub)"
        }
        NokhwaError::GetPropertyError { property, .. } if property == "CameraFormat" => {
            return DeviceError::Config(format!(
                "camera {device} offers no uncompressed video format (RGB3, BGR3, YUYV, NV12, \
                 GREY): MJPEG-only cameras and metadata nodes cannot be used; try another index"
            ));
        }
        NokhwaError::SetPropertyError { .. } => {
            return DeviceError::Config(format!(
                "camera {device}: {doing}: {text}; list its controls (UvcCamera::controls or \
                 `v4l2-ctl --list-ctrls`) to see what it accepts"
            ));
        }
        NokhwaError::ReadFrameError(_) => "check the cable; unplug and replug the camera",
        NokhwaError::ProcessFrameError { .. } => "the frame could not be decoded",
        _ => "check that the camera is connected and works with `v4l2-ctl`",
    };
    io_error(device, format!("{doing}: {text}; {hint}"))
}

/// An integer control's range, step, current value and writability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct IntControl {
    min: i64,
    max: i64,
    step: i64,
    value: i64,
    writable: bool,
}

impl IntControl {
    /// The integer range of `c`, if it has one.
    fn of(c: &CameraControl) -> Option<Self> {
        match *c.description() {
            ControlValueDescription::IntegerRange {
                min,
                max,
                value,
                step,
                ..
            } => Some(Self {
                min,
                max,
                step: step.max(1),
                value,
                writable: !c.flag().contains(&KnownCameraControlFlag::ReadOnly),
            }),
            _ => None,
        }
    }

    /// `v` rounded to the control's step and clamped to its range.
    fn snap(&self, v: f64) -> i64 {
        let steps = ((v - self.min as f64) / self.step as f64).round();
        let snapped = self
            .min
            .saturating_add((steps.max(0.0) as i64).saturating_mul(self.step));
        if snapped > self.max {
            self.max - (self.max - self.min) % self.step
        } else {
            snapped
        }
    }
}

/// `nokhwa`'s name for the V4L2 control `id`.
fn known(id: u32) -> KnownCameraControl {
    match id {
        CID_GAIN => KnownCameraControl::Gain,
        other => KnownCameraControl::Other(u128::from(other)),
    }
}

/// V4L2 id of a `nokhwa` control, for display.
fn v4l2_id(c: KnownCameraControl) -> Option<u128> {
    match c {
        KnownCameraControl::Gain => Some(u128::from(CID_GAIN)),
        KnownCameraControl::Other(id) => Some(id),
        _ => None,
    }
}

/// The controls the station drives, as found when the camera was opened.
#[derive(Debug, Clone, Default, PartialEq)]
struct ExposureControls {
    /// `exposure_time_absolute`.
    exposure: Option<IntControl>,
    /// `auto_exposure` menu.
    auto_exposure: Option<IntControl>,
    /// `gain`.
    gain: Option<IntControl>,
    /// `gain_automatic` (boolean or integer).
    autogain: Option<CameraControl>,
}

impl ExposureControls {
    /// Picks the exposure and gain controls out of a camera's list.
    fn from_list(list: &[CameraControl]) -> Self {
        let find = |id| list.iter().find(|c| c.control() == known(id));
        Self {
            exposure: find(CID_EXPOSURE_ABSOLUTE).and_then(IntControl::of),
            auto_exposure: find(CID_AUTO_EXPOSURE).and_then(IntControl::of),
            gain: find(CID_GAIN).and_then(IntControl::of),
            autogain: find(CID_AUTOGAIN)
                .filter(|c| !c.flag().contains(&KnownCameraControlFlag::ReadOnly))
                .cloned(),
        }
    }

    /// Whether the station can set the exposure time: a writable
    /// `exposure_time_absolute` with a positive range, and an `auto_exposure` menu
    /// (if any) that can be switched to manual.
    fn manual_exposure(&self) -> bool {
        let exposure_ok = self
            .exposure
            .is_some_and(|e| e.writable && e.max >= e.min && e.max > 0);
        let mode_ok = self
            .auto_exposure
            .is_none_or(|a| a.writable && (a.min..=a.max).contains(&AUTO_EXPOSURE_MANUAL));
        exposure_ok && mode_ok
    }

    /// Shortest and longest exposure time (s); zeros without the control.
    fn exposure_range_s(&self) -> [f64; 2] {
        self.exposure.map_or([0.0; 2], |e| {
            [
                e.min.max(1) as f64 * EXPOSURE_UNIT_S,
                e.max.max(0) as f64 * EXPOSURE_UNIT_S,
            ]
        })
    }

    /// The camera's facts for a `name`d camera delivering `width` × `height`.
    fn info(&self, name: &str, width_px: u32, height_px: u32) -> CameraInfo {
        CameraInfo {
            name: name.to_string(),
            width_px,
            height_px,
            bit_depth: 8,
            exposure_range_s: self.exposure_range_s(),
            gain_range: [1.0, 1.0],
            manual_exposure: self.manual_exposure(),
        }
    }
}

/// The best format this driver can decode: the most pixels (within
/// [`MAX_FRAME_PIXELS`]), then the preferred encoding, then the lowest frame rate.
fn choose_format(formats: &[CameraFormat]) -> Option<CameraFormat> {
    let rank = |f: FrameFormat| FORMATS.iter().position(|&x| x == f);
    formats
        .iter()
        .filter(|f| rank(f.format()).is_some() && (1..=1000).contains(&f.frame_rate()))
        .filter(|f| {
            let n = u64::from(f.width()) * u64::from(f.height());
            n > 0 && n <= MAX_FRAME_PIXELS
        })
        .max_by_key(|f| {
            let n = u64::from(f.width()) * u64::from(f.height());
            let r = rank(f.format()).map_or(0, |r| FORMATS.len() - r);
            (n, r, std::cmp::Reverse(f.frame_rate()))
        })
        .copied()
}

/// One line per control: name, V4L2 id, range, step and current value.
fn describe_control(c: &CameraControl) -> String {
    let id = v4l2_id(c.control()).map_or_else(|| c.control().to_string(), |i| format!("{i:#010x}"));
    let what = match *c.description() {
        ControlValueDescription::IntegerRange {
            min,
            max,
            value,
            step,
            ..
        } => format!("min {min}, max {max}, step {step}, current {value}"),
        ControlValueDescription::Boolean { value, .. } => format!("on/off, current {value}"),
        ref other => other.to_string(),
    };
    let unit = match v4l2_id(c.control()) {
        Some(i) if i == u128::from(CID_EXPOSURE_ABSOLUTE) => " (units of 100 µs)",
        _ => "",
    };
    let flags: Vec<String> = c.flag().iter().map(ToString::to_string).collect();
    let flags = if flags.is_empty() {
        String::new()
    } else {
        format!(" [{}]", flags.join(", "))
    };
    format!("{} ({id}): {what}{unit}{flags}", c.name())
}

/// A decoded RGB8 frame.
struct Decoded {
    width_px: u32,
    height_px: u32,
    rgb: Vec<[u16; 3]>,
    timestamp_s: f64,
}

/// Decodes a captured buffer to 8-bit RGB codes, refusing oversized frames before
/// allocating.
fn decode(device: &str, buffer: &Buffer) -> Result<Decoded, DeviceError> {
    let res = buffer.resolution();
    let (w, h) = (res.width(), res.height());
    let n = u64::from(w) * u64::from(h);
    if n == 0 || n > MAX_FRAME_PIXELS {
        return Err(DeviceError::Config(format!(
            "camera {device} delivers {w}×{h} frames: empty or larger than {MAX_FRAME_PIXELS} \
             pixels; choose a smaller resolution"
        )));
    }
    let n = usize::try_from(n).map_err(|_| io_error(device, format!("{w}×{h} frame too large")))?;
    let image = buffer
        .decode_image::<RgbFormat>()
        .map_err(|e| device_error(device, "decoding a frame", &e))?;
    let raw = image.into_raw();
    if raw.len() < 3 * n {
        return Err(io_error(
            device,
            format!(
                "frame of {} bytes is short of {w}×{h} RGB pixels; the camera sent a truncated \
                 frame: check the cable and USB bandwidth",
                raw.len()
            ),
        ));
    }
    let rgb = raw
        .chunks_exact(3)
        .take(n)
        .map(|p| [u16::from(p[0]), u16::from(p[1]), u16::from(p[2])])
        .collect();
    let timestamp_s = buffer.capture_timestamp().map_or_else(
        || {
            SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64())
        },
        |d| d.as_secs_f64(),
    );
    Ok(Decoded {
        width_px: w,
        height_px: h,
        rgb,
        timestamp_s,
    })
}

/// A V4L2/UVC camera driven with manual exposure.
pub struct UvcCamera {
    camera: nokhwa::Camera,
    /// `index: name`, for messages.
    device: String,
    controls: ExposureControls,
    info: CameraInfo,
}

impl fmt::Debug for UvcCamera {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("UvcCamera")
            .field("device", &self.device)
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl UvcCamera {
    /// Opens a camera by V4L2 index (`0`), device node (`/dev/video0`) or name
    /// (case-insensitive, else a part of it); of several with the name, the first
    /// that opens. Fails with [`DeviceError::NoCamera`], listing the cameras present,
    /// when none matches.
    pub fn open(index_or_name: &str) -> Result<Self, DeviceError> {
        let list = list_cameras()?;
        let mut first_error = None;
        for listing in match_cameras(&list, index_or_name) {
            match Self::open_listed(listing) {
                Ok(cam) => return Ok(cam),
                Err(e) => {
                    tracing::debug!("camera {listing} did not open: {e}");
                    first_error.get_or_insert(e);
                }
            }
        }
        Err(first_error.unwrap_or_else(|| no_camera(index_or_name, &list)))
    }

    /// Opens one listed device at its best uncompressed format.
    fn open_listed(listing: &CameraListing) -> Result<Self, DeviceError> {
        let device = format!("{}: {}", listing.index, listing.name);
        let wanted = RequestedFormat::with_formats(RequestedFormatType::None, &FORMATS);
        let mut camera = nokhwa::Camera::new(CameraIndex::Index(listing.index), wanted)
            .map_err(|e| device_error(&device, "opening the camera", &e))?;
        let formats = camera
            .compatible_camera_formats()
            .map_err(|e| device_error(&device, "listing its formats", &e))?;
        if let Some(best) = choose_format(&formats)
            && best != camera.camera_format()
            && let Err(e) = camera.set_camera_requset(RequestedFormat::with_formats(
                RequestedFormatType::Exact(best),
                &FORMATS,
            ))
        {
            tracing::warn!(
                "camera {device}: keeping {}: {best} refused: {e}",
                camera.camera_format()
            );
        }
        let list = camera
            .camera_controls()
            .map_err(|e| device_error(&device, "reading its controls", &e))?;
        let controls = ExposureControls::from_list(&list);
        let res = camera.resolution();
        let info = controls.info(&listing.name, res.width(), res.height());
        if !info.manual_exposure {
            tracing::warn!("camera {device} has no manual exposure control; capture will refuse");
        }
        Ok(Self {
            camera,
            device,
            controls,
            info,
        })
    }

    /// The camera's controls, one line each: name, V4L2 id, min, max, step, current
    /// value and flags; `exposure_time_absolute` (id 0x009a0902) and
    /// `auto_exposure` (0x009a0901) tell whether manual exposure exists.
    pub fn controls(&self) -> Result<Vec<String>, DeviceError> {
        let list = self
            .camera
            .camera_controls()
            .map_err(|e| device_error(&self.device, "reading its controls", &e))?;
        Ok(list.iter().map(describe_control).collect())
    }

    /// Sets one control, with an error naming it and the value.
    fn set(&mut self, what: &str, id: u32, value: ControlValueSetter) -> Result<(), DeviceError> {
        let doing = format!("setting {what} to {value}");
        self.camera
            .set_camera_control(known(id), value)
            .map_err(|e| device_error(&self.device, &doing, &e))
    }

    /// Switches to manual exposure at `exposure_s` and lowest gain; returns the
    /// exposure time actually set (s), rounded to the camera's step.
    fn apply_exposure(&mut self, exposure_s: f64) -> Result<f64, DeviceError> {
        let c = self.controls.clone();
        let exposure = c
            .exposure
            .ok_or_else(|| DeviceError::AutoExposureOnly(self.device.clone()))?;
        if c.auto_exposure.is_some() {
            let manual = ControlValueSetter::Integer(AUTO_EXPOSURE_MANUAL);
            self.set("auto_exposure", CID_AUTO_EXPOSURE, manual)?;
        }
        if let Some(a) = &c.autogain {
            let off = match a.description() {
                ControlValueDescription::Boolean { .. } => ControlValueSetter::Boolean(false),
                _ => ControlValueSetter::Integer(0),
            };
            self.set("gain_automatic", CID_AUTOGAIN, off)?;
        }
        if let Some(g) = c.gain.filter(|g| g.writable && g.value != g.min) {
            self.set("gain", CID_GAIN, ControlValueSetter::Integer(g.min))?;
            if let Some(gain) = &mut self.controls.gain {
                gain.value = g.min;
            }
        }
        let units = exposure.snap(exposure_s / EXPOSURE_UNIT_S).max(1);
        let what = format!(
            "exposure_time_absolute ({} s)",
            units as f64 * EXPOSURE_UNIT_S
        );
        self.set(
            &what,
            CID_EXPOSURE_ABSOLUTE,
            ControlValueSetter::Integer(units),
        )?;
        Ok(units as f64 * EXPOSURE_UNIT_S)
    }

    /// Starts the stream, discards [`DISCARD_FRAMES`] frames, grabs and decodes one,
    /// and stops the stream (so that no stale, queued frame is ever returned).
    fn grab(&mut self) -> Result<Decoded, DeviceError> {
        self.camera
            .open_stream()
            .map_err(|e| device_error(&self.device, "starting the video stream", &e))?;
        let result = self.read_frame();
        if let Err(e) = self.camera.stop_stream() {
            tracing::warn!("camera {}: stopping the stream: {e}", self.device);
        }
        result
    }

    /// Reads frames from the open stream; decodes the last.
    fn read_frame(&mut self) -> Result<Decoded, DeviceError> {
        for _ in 0..DISCARD_FRAMES {
            self.camera
                .frame()
                .map_err(|e| device_error(&self.device, "reading a frame", &e))?;
        }
        let buffer = self
            .camera
            .frame()
            .map_err(|e| device_error(&self.device, "reading a frame", &e))?;
        decode(&self.device, &buffer)
    }
}

impl Camera for UvcCamera {
    fn info(&self) -> CameraInfo {
        self.info.clone()
    }

    fn capture(&mut self, exposure_s: f64, gain: f64) -> Result<Frame, DeviceError> {
        self.info().check_request(exposure_s, gain)?;
        let exposure_s = self.apply_exposure(exposure_s)?;
        let d = self.grab()?;
        Ok(Frame {
            width_px: d.width_px,
            height_px: d.height_px,
            bit_depth: 8,
            rgb: d.rgb,
            exposure_s,
            gain,
            timestamp_s: d.timestamp_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listing(index: u32, name: &str) -> CameraListing {
        CameraListing {
            index,
            name: name.to_string(),
            description: format!("Video4Linux Device @ /dev/video{index}"),
            misc: String::new(),
        }
    }

    fn int(
        id: u32,
        min: i64,
        max: i64,
        value: i64,
        flags: Vec<KnownCameraControlFlag>,
    ) -> CameraControl {
        let description = ControlValueDescription::IntegerRange {
            min,
            max,
            value,
            step: 1,
            default: value,
        };
        CameraControl::new(known(id), format!("ctrl {id:#x}"), description, flags, true)
    }

    #[test]
    fn cameras_match_by_index_node_exact_name_then_part_of_a_name() {
        let list = [
            listing(0, "HD Webcam"),
            listing(1, "HD Webcam"),
            listing(4, "Lab Cam Pro"),
        ];
        let idx = |q: &str| {
            match_cameras(&list, q)
                .iter()
                .map(|c| c.index)
                .collect::<Vec<_>>()
        };
        assert_eq!(idx("4"), [4]);
        assert_eq!(idx("/dev/video1"), [1]);
        assert_eq!(idx("hd webcam"), [0, 1]);
        assert_eq!(idx("cam pro"), [4]);
        assert!(idx("7").is_empty());
        assert!(idx("  ").is_empty());
        assert!(idx("projector").is_empty());
    }

    #[test]
    fn no_camera_message_names_the_request_and_lists_the_cameras_present() {
        let msg = no_camera("Lab Cam", &[listing(0, "HD Webcam")]).to_string();
        assert!(
            msg.contains("\"Lab Cam\"") && msg.contains("0: HD Webcam"),
            "{msg}"
        );
        let msg = no_camera("0", &[]).to_string();
        assert!(msg.contains("no video devices found"), "{msg}");
    }

    #[test]
    fn exposure_absolute_in_100_us_units_gives_the_range_in_seconds_and_manual_exposure() {
        let list = [
            int(CID_AUTO_EXPOSURE, 0, 3, 3, vec![]),
            int(
                CID_EXPOSURE_ABSOLUTE,
                3,
                2047,
                250,
                vec![KnownCameraControlFlag::Disabled],
            ),
            int(CID_GAIN, 0, 255, 64, vec![]),
        ];
        let info = ExposureControls::from_list(&list).info("cam", 640, 480);
        assert!(info.manual_exposure);
        assert!((info.exposure_range_s[0] - 3e-4).abs() < 1e-12);
        assert!((info.exposure_range_s[1] - 0.2047).abs() < 1e-12);
        assert_eq!(info.gain_range, [1.0, 1.0]);
        assert!(info.check_request(0.01, 1.0).is_ok());
    }

    #[test]
    fn a_camera_without_a_settable_exposure_time_reports_auto_exposure_only() {
        let no_control = ExposureControls::from_list(&[int(CID_GAIN, 0, 255, 64, vec![])]);
        let read_only = ExposureControls::from_list(&[int(
            CID_EXPOSURE_ABSOLUTE,
            1,
            5000,
            100,
            vec![KnownCameraControlFlag::ReadOnly],
        )]);
        let auto_only = ExposureControls::from_list(&[
            int(CID_AUTO_EXPOSURE, 3, 3, 3, vec![]),
            int(CID_EXPOSURE_ABSOLUTE, 1, 5000, 100, vec![]),
        ]);
        for c in [no_control, read_only, auto_only] {
            let info = c.info("cam", 640, 480);
            assert!(!info.manual_exposure, "{c:?}");
            let e = info.check_request(0.01, 1.0).unwrap_err();
            assert!(matches!(e, DeviceError::AutoExposureOnly(_)), "{e}");
        }
    }

    #[test]
    fn exposure_requests_snap_to_the_control_step_within_its_range() {
        let c = IntControl {
            min: 3,
            max: 2047,
            step: 4,
            value: 3,
            writable: true,
        };
        assert_eq!(c.snap(100.0), 99);
        assert_eq!(c.snap(101.2), 103);
        assert_eq!(c.snap(0.0), 3);
        assert_eq!(c.snap(1e9), 2047);
        let c = IntControl {
            min: 1,
            max: 10,
            step: 4,
            value: 1,
            writable: true,
        };
        assert_eq!(c.snap(10.0), 9);
    }

    #[test]
    fn the_largest_uncompressed_format_wins_at_its_lowest_frame_rate() {
        let f = |w, h, ff, fps| CameraFormat::new_from(w, h, ff, fps);
        let formats = [
            f(1920, 1080, FrameFormat::MJPEG, 30),
            f(1280, 720, FrameFormat::YUYV, 10),
            f(1280, 720, FrameFormat::YUYV, 5),
            f(1280, 720, FrameFormat::NV12, 5),
            f(640, 480, FrameFormat::YUYV, 30),
        ];
        assert_eq!(
            choose_format(&formats),
            Some(f(1280, 720, FrameFormat::YUYV, 5))
        );
        assert_eq!(choose_format(&formats[..1]), None);
    }

    #[test]
    fn control_lines_show_name_id_range_and_current_value() {
        let line = describe_control(&int(CID_EXPOSURE_ABSOLUTE, 3, 2047, 250, vec![]));
        assert!(line.contains("0x009a0902"), "{line}");
        assert!(
            line.contains("min 3, max 2047, step 1, current 250"),
            "{line}"
        );
        assert!(line.contains("100 µs"), "{line}");
    }

    #[test]
    fn frames_larger_than_the_limit_are_refused_before_decoding() {
        let res = nokhwa::utils::Resolution::new(1 << 16, 1 << 16);
        let buffer = Buffer::new(res, &[0u8; 16], FrameFormat::GRAY);
        let e = decode("test", &buffer)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("larger than"), "{e}");
    }

    #[test]
    fn a_yuyv_buffer_decodes_to_8_bit_rgb_codes() {
        let res = nokhwa::utils::Resolution::new(2, 1);
        let buffer = Buffer::new(res, &[128, 128, 128, 128], FrameFormat::YUYV);
        let d = decode("test", &buffer).map_err(|e| e.to_string()).unwrap();
        assert_eq!((d.width_px, d.height_px, d.rgb.len()), (2, 1, 2));
        assert!(
            d.rgb.iter().flatten().all(|&c| (100..=160).contains(&c)),
            "{:?}",
            d.rgb
        );
        let short = Buffer::new(
            nokhwa::utils::Resolution::new(4, 4),
            &[0u8; 8],
            FrameFormat::GRAY,
        );
        assert!(decode("test", &short).is_err());
    }
}
