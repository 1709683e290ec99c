use crate::geom::SimBox;
use serde::{Deserialize, Serialize};

/// Periodic box of one frame (simulations, LAMMPS dumps). Lengths in the tracks' unit.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct FrameBox {
    pub frame: i64,
    pub x_lo: f64,
    pub y_lo: f64,
    pub lx: f64,
    pub ly: f64,
    /// Lees–Edwards offset: x shift of the periodic image above (length unit).
    pub xy: f64,
    pub periodic_x: bool,
    pub periodic_y: bool,
}

impl FrameBox {
    pub fn from_simbox(frame: i64, b: &SimBox) -> FrameBox {
        FrameBox {
            frame,
            x_lo: b.x_lo,
            y_lo: b.y_lo,
            lx: b.lx,
            ly: b.ly,
            xy: b.xy,
            periodic_x: b.periodic_x,
            periodic_y: b.periodic_y,
        }
    }
    pub fn simbox(&self) -> SimBox {
        SimBox {
            x_lo: self.x_lo,
            y_lo: self.y_lo,
            lx: self.lx,
            ly: self.ly,
            xy: self.xy,
            periodic_x: self.periodic_x,
            periodic_y: self.periodic_y,
        }
    }
}

/// Where a table came from: enough to reproduce it.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Provenance {
    pub tool: String,
    pub tool_version: String,
    pub source: String,
    pub source_format: String,
    pub source_sha256: String,
    #[serde(default)]
    pub parameters: serde_json::Value,
}

/// The `<table>.meta.json` sidecar (`data_schema/tracks_meta.schema.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TracksMeta {
    pub schema: String,
    pub schema_version: u32,
    /// Unit of x, y, radius and boxes ("cm", "px", "d_s", ...).
    pub length_unit: String,
    /// Unit of `time` and `frame_time` ("s", "tau_e", ...).
    pub time_unit: String,
    /// Time between consecutive frames (time_unit), if known.
    pub frame_time: Option<f64>,
    /// Bar speed v_c (length_unit / time_unit), if known.
    #[serde(default)]
    pub bar_speed: Option<f64>,
    /// trackpy's median `ep` (its static localisation error estimate), in length_unit,
    /// when the tracks came from trackpy with that column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_error_ep: Option<f64>,
    pub coordinate_frame: String,
    #[serde(default)]
    pub boxes: Vec<FrameBox>,
    #[serde(default)]
    pub provenance: Provenance,
    #[serde(default)]
    pub summary: serde_json::Value,
    /// What the reader could not do that bears on the numbers (e.g. a LAMMPS dump read
    /// with wrapped positions). Absent from the sidecar when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

impl Default for TracksMeta {
    fn default() -> Self {
        TracksMeta {
            schema: "tracks".into(),
            schema_version: 1,
            length_unit: "unspecified".into(),
            time_unit: "s".into(),
            frame_time: None,
            bar_speed: None,
            position_error_ep: None,
            coordinate_frame: "as given by the source".into(),
            boxes: Vec::new(),
            provenance: Provenance::default(),
            summary: serde_json::Value::Null,
            warnings: Vec::new(),
        }
    }
}

impl TracksMeta {
    /// The periodic box of `frame`, if the tracks have one (boxes are sorted by frame).
    pub fn box_at(&self, frame: i64) -> Option<SimBox> {
        if self.boxes.is_empty() {
            return None;
        }
        match self.boxes.binary_search_by_key(&frame, |b| b.frame) {
            Ok(i) => Some(self.boxes[i].simbox()),
            // A single box applies to every frame.
            Err(_) if self.boxes.len() == 1 => Some(self.boxes[0].simbox()),
            Err(_) => None,
        }
    }
}
