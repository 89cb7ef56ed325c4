//! The tube's predicted outline in one camera: points on its contour generators (where the
//! viewing rays graze the surface), projected through the lens model, with the outline's
//! normal in the image and how far the outline moves per millimetre the surface moves.
//!
//! The tube is the envelope of spheres of radius `r` centred on the centerline `C(u)`. At `u`
//! its surface is the circle `C + r·n`, `n ⊥ C'`; a viewing ray from the camera centre `O`
//! grazes it where `n·(C + r·n − O) = 0`, i.e. `n·(C − O) = −r`: two points, one each side. The
//! caps are spheres about the end points; their grazing circle is cut to the half beyond the
//! end. By the envelope theorem, moving the centerline by `δC(u)` and the radius by `δr` moves
//! the surface at such a point by `n·δC(u) + δr` along `n`, and the image outline by that times
//! `gain = m·(∂pixel/∂X)·n` along its image normal `m`: the fit's analytic Jacobian.

use flexshape_camera::Camera;
use flexshape_curve::Basis;
use nalgebra::{Point3, Vector2, Vector3};

use crate::tube::Tube;

/// Which part of the tube a sample lies on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Part {
    /// The side, at the centerline parameter's basis functions.
    Side(Basis),
    /// The cap at the proximal end (`0`) or the tip (`1`).
    Cap(usize),
}

/// One predicted outline point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct OutlinePoint {
    /// Pixel (OpenCV convention).
    pub pixel: Vector2<f64>,
    /// Unit image normal, pointing out of the tube's image.
    pub normal: Vector2<f64>,
    /// Pixels the outline moves along `normal` per mm the surface moves along `surface`.
    pub gain: f64,
    /// Unit surface normal at the grazing point (world).
    pub surface: Vector3<f64>,
    /// Distance from the outline to the projected centerline, pixels (how far inside the
    /// tube's image a search may look).
    pub half_width: f64,
    /// Share of an independent measurement this sample is: the outline length it stands for
    /// in the image, in pixels, at most 1 (a tube seen end-on crowds many samples into a few
    /// pixels of outline).
    pub weight: f64,
    /// Where on the tube.
    pub part: Part,
    /// Which radius section (0: the tip's, whose radius the fit may move; see
    /// [`Tube::radius_at`]).
    pub section: usize,
    /// Centerline parameter of the sample.
    pub u: f64,
    /// Which grazing point: the side (±1) for a side sample, the angle around the grazing
    /// circle (radians) for a cap sample.
    pub which: f64,
    /// The grazing point, world mm.
    pub world: Point3<f64>,
}

/// A side sample's place on the centerline: parameter, basis, centre, unit tangent and radius
/// section.
type Station = (f64, Basis, Point3<f64>, Vector3<f64>, usize);

/// What every camera's outline of one tube shares, computed once: the centerline at the
/// outline samples (about every `spacing_mm`) and the centres of the spheres, every half
/// radius, that stand for the tube in visibility tests.
pub(crate) struct Sampled {
    /// The centerline's length, mm.
    length: f64,
    /// Tube length a side sample stands for, mm.
    stride: f64,
    /// Per side sample (samples at a radius step's shoulder are left out).
    sides: Vec<Station>,
    /// Sphere centres along the centerline and their radii, world mm.
    centres: Vec<(Point3<f64>, f64)>,
    /// Each radius step's shoulder: where it is on the centerline and the larger radius,
    /// world mm.
    shoulders: Vec<(Point3<f64>, f64)>,
}

impl Sampled {
    pub(crate) fn new(tube: &Tube, spacing_mm: f64) -> Self {
        let length = tube.length();
        let n = (length / spacing_mm).ceil().max(4.0) as usize;
        let sides = (0..=n)
            .map(|i| i as f64 / n as f64)
            .filter(|&u| !tube.at_shoulder(u, length))
            .map(|u| {
                // The Jacobian needs the values only, the frame the tangent.
                let basis = tube.centerline.basis_to::<1>(u);
                let at = tube.centerline.eval_basis(&basis);
                let t = Vector3::from(at.d1);
                let section = tube.section_at(u, length);
                (
                    u,
                    basis,
                    Point3::from(at.value),
                    t / t.norm().max(1e-300),
                    section,
                )
            })
            .collect();
        let shoulders = tube
            .shoulders()
            .map(|(at, larger)| (tube.frame((1.0 - at / length).clamp(0.0, 1.0)).0, larger))
            .collect();
        Sampled {
            length,
            stride: length / n as f64,
            sides,
            centres: sphere_centres(tube, length),
            shoulders,
        }
    }
}

/// How far beyond a radius step's shoulder image its side points are left out, pixels: the
/// boundary search's default reach (3 px) and a pixel for the edge's rise.
const SHOULDER_CLEARANCE_PX: f64 = 4.0;

/// Centres of spheres every half (smallest) radius along the centerline and their radii,
/// world mm.
pub(crate) fn sphere_centres(tube: &Tube, length: f64) -> Vec<(Point3<f64>, f64)> {
    let smallest = tube
        .steps
        .iter()
        .map(|s| s.radius_mm)
        .fold(tube.radius, f64::min);
    let n = (length / (smallest / 2.0)).ceil().max(4.0) as usize;
    (0..=n)
        .map(|i| {
            let u = i as f64 / n as f64;
            (tube.frame(u).0, tube.radius_at(u, length))
        })
        .collect()
}

/// The outline of `tube` in `camera` at the samples of `sampled` (both sides) and over the
/// caps. Points the camera cannot project (behind it, beyond the lens model's fold) or that
/// fall outside the image are left out.
pub(crate) fn outline(
    camera: &Camera,
    tube: &Tube,
    sampled: &Sampled,
    spacing_mm: f64,
    clearance_px: f64,
) -> Vec<OutlinePoint> {
    let mut out = Vec::with_capacity(2 * sampled.sides.len() + 40);
    let eye = camera.centre();
    // A shoulder's image, widened by how far a boundary search reaches: a side point there
    // would find the shoulder's rounded edge, which the model leaves out. Along the tube
    // `Tube::at_shoulder` leaves out a few millimetres; a camera that sees the step obliquely
    // sees the thinner tube within the shoulder's disc much farther (at 640×480, 15 of a
    // camera's 159 points, the first 8 mm past the shoulder, 0.6–1.8 px off).
    let shoulders: Vec<(Vector2<f64>, f64)> = sampled
        .shoulders
        .iter()
        .filter_map(|&(p, r)| sphere(camera, p, r))
        .map(|(_, px, rp)| (px, rp + SHOULDER_CLEARANCE_PX))
        .collect();
    let at_shoulder = |q: &Vector2<f64>| shoulders.iter().any(|(c, reach)| (q - c).norm() < *reach);
    for (u, basis, c, t, section) in &sampled.sides {
        let Ok(centre) = camera.project(c) else {
            continue;
        };
        let at = Centre {
            u: *u,
            basis: *basis,
            point: c,
            pixel: centre.pixel.coords,
            tangent: t,
            section: *section,
        };
        for side in [-1.0, 1.0] {
            out.extend(
                side_at(
                    camera,
                    &eye,
                    tube.section_radius(*section),
                    &at,
                    side,
                    sampled.stride,
                )
                .filter(|p| !at_shoulder(&p.pixel)),
            );
        }
    }
    for end in [0, 1] {
        if let Some(cap) = CapView::new(camera, tube, end, sampled.length) {
            // The caps decide where the tip is: sampled at least every CAP_SPACING_MM
            // whatever the sides' spacing (a few samples more).
            let step = spacing_mm.min(CAP_SPACING_MM);
            let count = ((2.0 * cap.phi_max * cap.r / step).ceil() as usize).max(3);
            for k in 0..count {
                // Strictly inside the half, whose ends are the sides' last points.
                let phi = cap.phi_max * (2.0 * (k as f64 + 0.5) / count as f64 - 1.0);
                out.extend(cap.point(camera, phi));
            }
        }
    }
    let spheres = Spheres::from_centres(camera, tube, &sampled.centres, clearance_px);
    let eye = camera.centre();
    out.retain(|p| !spheres.hide(&eye, p));
    out
}

/// Largest spacing of a cap's outline samples, mm.
const CAP_SPACING_MM: f64 = 2.0;

/// The same outline point as `p` (same place along the tube, same side or cap angle) on a
/// moved `tube`; `stride` the tube length a side sample stands for, mm.
pub(crate) fn again(
    camera: &Camera,
    tube: &Tube,
    p: &OutlinePoint,
    stride: f64,
) -> Option<OutlinePoint> {
    match p.part {
        Part::Side(basis) => {
            let at = tube.centerline.eval_basis(&basis);
            let t = Vector3::from(at.d1);
            let t = t / t.norm().max(1e-300);
            let c = Point3::from(at.value);
            let centre = Centre {
                u: p.u,
                basis,
                point: &c,
                pixel: camera.project(&c).ok()?.pixel.coords,
                tangent: &t,
                section: p.section,
            };
            side_at(
                camera,
                &camera.centre(),
                tube.section_radius(p.section),
                &centre,
                p.which,
                stride,
            )
        }
        Part::Cap(end) => {
            CapView::with_section(camera, tube, end, p.section)?.point(camera, p.which)
        }
    }
}

/// A centerline point an outline sample stands on.
struct Centre<'a> {
    u: f64,
    basis: Basis,
    point: &'a Point3<f64>,
    /// Its pixel in the camera.
    pixel: Vector2<f64>,
    /// Unit tangent.
    tangent: &'a Vector3<f64>,
    /// Radius section.
    section: usize,
}

/// The side outline point on side `side` (±1) at the centerline point `at`, seen from `eye`;
/// `r` the tube's radius.
fn side_at(
    camera: &Camera,
    eye: &Point3<f64>,
    r: f64,
    at: &Centre<'_>,
    side: f64,
    stride: f64,
) -> Option<OutlinePoint> {
    let (c, t) = (at.point, at.tangent);
    let v = c - eye;
    let v_perp = v - t * v.dot(t);
    let d = v_perp.norm();
    if d <= 1.5 * r {
        return None;
    }
    let e1 = v_perp / d;
    let e2 = t.cross(&e1);
    let a = -r / d;
    let b = (1.0 - a * a).sqrt();
    let normal = e1 * a + e2 * (side * b);
    let sample = Sample {
        part: Part::Side(at.basis),
        section: at.section,
        u: at.u,
        which: side,
        stride: Some((*t, stride)),
    };
    grazing(camera, at.pixel, c, eye, normal, r, sample)
}

/// A cap as one camera sees it: the sphere about an end, its grazing circle, and the half of
/// it beyond the end.
struct CapView {
    end: usize,
    /// The cap's radius and radius section.
    r: f64,
    section: usize,
    u: f64,
    centre: Point3<f64>,
    centre_px: Vector2<f64>,
    /// Unit view direction to the centre, and two unit axes across it (`f1` toward the cap).
    vh: Vector3<f64>,
    f1: Vector3<f64>,
    f2: Vector3<f64>,
    /// `r / distance` and the grazing circle's radius over `r`.
    ratio: f64,
    s: f64,
    /// The half beyond the end spans `φ ∈ (−phi_max, phi_max)`.
    phi_max: f64,
}

impl CapView {
    /// `None` for an open end, or one the camera sees end-on (no cap outline of its own);
    /// `length` the tube's, mm (it places the proximal end's radius section).
    fn new(camera: &Camera, tube: &Tube, end: usize, length: f64) -> Option<Self> {
        let section = if end == 0 {
            tube.section_at(0.0, length)
        } else {
            0
        };
        Self::with_section(camera, tube, end, section)
    }

    /// As [`CapView::new`], the end's radius section given.
    fn with_section(camera: &Camera, tube: &Tube, end: usize, section: usize) -> Option<Self> {
        if !tube.capped[end] {
            return None;
        }
        let r = tube.section_radius(section);
        let u = end as f64;
        let (c, t) = tube.frame(u);
        // The cap's axis points away from the tube.
        let axis = if end == 0 { -t } else { t };
        let v = c - camera.centre();
        let dist = v.norm();
        if dist <= 1.5 * r {
            return None;
        }
        let vh = v / dist;
        let t_perp = axis - vh * axis.dot(&vh);
        let tp = t_perp.norm();
        if tp < 0.2 {
            return None;
        }
        let f1 = t_perp / tp;
        let ratio = r / dist;
        let s = (1.0 - ratio * ratio).sqrt();
        // n·axis > 0 ⇔ cos φ > cos_min.
        let cos_min = (ratio * vh.dot(&axis) / (s * tp)).clamp(-1.0, 1.0);
        Some(CapView {
            end,
            r,
            section,
            u,
            centre: c,
            centre_px: camera.project(&c).ok()?.pixel.coords,
            vh,
            f1,
            f2: vh.cross(&f1),
            ratio,
            s,
            phi_max: cos_min.acos(),
        })
    }

    /// The cap's outline point at angle `phi` around the grazing circle.
    fn point(&self, camera: &Camera, phi: f64) -> Option<OutlinePoint> {
        let normal = -self.vh * self.ratio + (self.f1 * phi.cos() + self.f2 * phi.sin()) * self.s;
        let sample = Sample {
            part: Part::Cap(self.end),
            section: self.section,
            u: self.u,
            which: phi,
            stride: None,
        };
        let eye = camera.centre();
        grazing(
            camera,
            self.centre_px,
            &self.centre,
            &eye,
            normal,
            self.r,
            sample,
        )
    }
}

/// Where a sample is on the tube.
struct Sample {
    part: Part,
    section: usize,
    u: f64,
    which: f64,
    /// For a side sample: the centerline's unit tangent and the tube length it stands for, mm.
    stride: Option<(Vector3<f64>, f64)>,
}

/// The outline point of the surface point `centre + r·normal`.
fn grazing(
    camera: &Camera,
    centre_px: Vector2<f64>,
    centre: &Point3<f64>,
    eye: &Point3<f64>,
    normal: Vector3<f64>,
    r: f64,
    sample: Sample,
) -> Option<OutlinePoint> {
    let x = centre + normal * r;
    let (proj, j) = camera.project_with_jacobian(&x).ok()?;
    let pixel = proj.pixel.coords;
    let intr = &camera.intrinsics;
    if pixel.x < 1.0
        || pixel.y < 1.0
        || pixel.x > intr.width as f64 - 2.0
        || pixel.y > intr.height as f64 - 2.0
    {
        return None;
    }
    // The tangent plane holds the ray; any other direction in it maps onto the outline.
    let along = j * normal.cross(&(x - eye));
    let len = along.norm();
    if len < 1e-12 {
        return None;
    }
    let mut m = Vector2::new(-along.y, along.x) / len;
    let push = j * normal;
    let mut gain = m.dot(&push);
    if gain < 0.0 {
        m = -m;
        gain = -gain;
    }
    if gain < 1e-6 {
        return None;
    }
    // Pixels of outline the sample stands for: the image of its stretch of tube along the
    // outline.
    let weight = sample.stride.map_or(1.0, |(t, mm)| {
        let outline_dir = Vector2::new(-m.y, m.x);
        ((j * t).dot(&outline_dir).abs() * mm).min(1.0)
    });
    Some(OutlinePoint {
        pixel,
        normal: m,
        gain,
        surface: normal,
        half_width: (pixel - centre_px).dot(&m).max(0.0),
        weight,
        part: sample.part,
        section: sample.section,
        u: sample.u,
        which: sample.which,
        world: x,
    })
}

/// The tube as spheres half a radius apart along its centerline, each open end continued
/// straight until it leaves the image (the tube goes on beyond the volume), for visibility.
/// An outline point counts only where its boundary is the tube's against the background:
/// not when its viewing ray enters the tube in front of it (the tube crossing itself, or seen
/// along its length), nor when the pixels just outside it show the tube too (another part
/// behind or beside it).
pub(crate) struct Spheres {
    /// Centre (world), its pixel, and the sphere's image radius in pixels: the tube's
    /// (`..tube_items`), then its open ends' continuations.
    items: Vec<(Point3<f64>, Vector2<f64>, f64)>,
    tube_items: usize,
    /// Each sphere's radius, mm.
    radii: Vec<f64>,
    /// Each sphere's centerline parameter (an open end's continuation: its end's, 0 or 1).
    us: Vec<f64>,
    /// Per sphere, squared: its image radius less a quarter pixel (a pixel it surely covers)
    /// and plus a pixel (beyond, it surely does not), pixels².
    reach2: Vec<(f64, f64)>,
    /// How far outside an outline point the image must show background, pixels.
    clearance: f64,
    /// The spheres whose image (plus a pixel) meets each cell of a grid over the image.
    grid: Grid,
}

/// Cells of `CELL` pixels over the part of the image the spheres reach, each listing the
/// spheres that may cover it.
struct Grid {
    /// The first cell's column and row in the image's grid.
    x0: usize,
    y0: usize,
    columns: usize,
    rows: usize,
    /// Cell `i` holds `members[starts[i]..starts[i + 1]]`.
    starts: Vec<u32>,
    members: Vec<u32>,
}

/// Grid cell edge, pixels.
const CELL: f64 = 8.0;

impl Grid {
    fn new(width: f64, height: f64, items: &[(Point3<f64>, Vector2<f64>, f64)]) -> Self {
        // The image's cells, then those the spheres reach: a tube covers a small part of the
        // image, and the counts are cleared and summed over every cell.
        let all = [
            (width / CELL).ceil().max(1.0) as usize,
            (height / CELL).ceil().max(1.0) as usize,
        ];
        let cell = |v: f64, k: usize| (v / CELL).floor().clamp(0.0, (all[k] - 1) as f64) as usize;
        let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
        for (_, px, rp) in items {
            let reach = rp + 1.0;
            for k in 0..2 {
                lo[k] = lo[k].min(cell(px[k] - reach, k));
                hi[k] = hi[k].max(cell(px[k] + reach, k));
            }
        }
        if items.is_empty() {
            (lo, hi) = ([0; 2], [0; 2]);
        }
        let [x0, y0] = lo;
        let (columns, rows) = (hi[0] - x0 + 1, hi[1] - y0 + 1);
        let span =
            |lo: f64, hi: f64, k: usize| cell(lo, k) - [x0, y0][k]..=cell(hi, k) - [x0, y0][k];
        let cells = |(_, px, rp): &(Point3<f64>, Vector2<f64>, f64)| {
            let reach = rp + 1.0;
            let xs = span(px.x - reach, px.x + reach, 0);
            span(px.y - reach, px.y + reach, 1)
                .flat_map(move |y| xs.clone().map(move |x| y * columns + x))
        };
        let mut counts = vec![0u32; columns * rows + 1];
        for item in items {
            for c in cells(item) {
                counts[c + 1] += 1;
            }
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let mut members = vec![0u32; counts[columns * rows] as usize];
        for (i, item) in items.iter().enumerate() {
            for c in cells(item) {
                members[fill[c] as usize] = i as u32;
                fill[c] += 1;
            }
        }
        Grid {
            x0,
            y0,
            columns,
            rows,
            starts: counts,
            members,
        }
    }

    /// The grid cell of pixel `p`, `None` outside the grid.
    fn cell(&self, p: Vector2<f64>) -> Option<usize> {
        // Truncation is the floor for the positions kept (and no library call).
        if !(p.x >= 0.0 && p.y >= 0.0) {
            return None;
        }
        let (x, y) = (
            ((p.x / CELL) as usize).wrapping_sub(self.x0),
            ((p.y / CELL) as usize).wrapping_sub(self.y0),
        );
        // Left of or above the grid wraps round to beyond it.
        (x < self.columns && y < self.rows).then_some(y * self.columns + x)
    }

    /// The spheres that may cover the pixels of `cell`.
    fn members(&self, cell: Option<usize>) -> &[u32] {
        match cell {
            Some(c) => &self.members[self.starts[c] as usize..self.starts[c + 1] as usize],
            None => &[],
        }
    }

    /// The spheres that may cover pixel `p`.
    fn near(&self, p: Vector2<f64>) -> &[u32] {
        self.members(self.cell(p))
    }
}

impl Spheres {
    /// The spheres about `centres` (along the centerline, see [`sphere_centres`]) and the
    /// continuations of the tube's open ends in `camera`'s image; `clearance` as in `hide`.
    pub(crate) fn from_centres(
        camera: &Camera,
        tube: &Tube,
        centres: &[(Point3<f64>, f64)],
        clearance: f64,
    ) -> Self {
        // The centres are evenly spaced in the centerline's parameter.
        let last = centres.len().saturating_sub(1).max(1) as f64;
        let (mut items, mut radii, mut us) = (Vec::new(), Vec::new(), Vec::new());
        for (i, (s, &(_, r))) in spheres_along(camera, centres)
            .into_iter()
            .zip(centres)
            .enumerate()
        {
            if let Some(s) = s {
                items.push(s);
                radii.push(r);
                us.push(i as f64 / last);
            }
        }
        let tube_items = items.len();
        let (w, h) = (
            camera.intrinsics.width as f64,
            camera.intrinsics.height as f64,
        );
        for end in [0, 1] {
            if tube.capped[end] {
                continue;
            }
            let (c, dir) = tube.beyond(end);
            let r = match (end, centres.first(), centres.last()) {
                (0, Some(first), _) => first.1,
                (_, _, Some(last)) => last.1,
                _ => tube.radius,
            };
            let beyond: Vec<(Point3<f64>, f64)> = (1..=(BEYOND_MM / (r / 2.0)).ceil() as usize)
                .map(|k| (c + dir * (k as f64 * r / 2.0), r))
                .collect();
            for s in spheres_along(camera, &beyond) {
                let Some(s) = s else { break };
                let (px, rp) = (s.1, s.2);
                if px.x < -rp || px.y < -rp || px.x > w + rp || px.y > h + rp {
                    break;
                }
                items.push(s);
                radii.push(r);
                us.push(end as f64);
            }
        }
        Spheres {
            grid: Grid::new(w, h, &items),
            reach2: items
                .iter()
                .map(|(_, _, rp)| {
                    let inner = (rp - 0.25).max(0.0);
                    (inner * inner, (rp + 1.0) * (rp + 1.0))
                })
                .collect(),
            items,
            tube_items,
            radii,
            us,
            clearance,
        }
    }

    /// The tube's spheres as the camera sees them.
    pub(crate) fn tube(&self) -> &[Projected] {
        &self.items[..self.tube_items]
    }

    /// Those of its open ends' straight continuations, until they leave the image.
    pub(crate) fn beyond(&self) -> &[Projected] {
        &self.items[self.tube_items..]
    }

    /// The centerline parameters of [`Spheres::tube`]'s spheres, then of
    /// [`Spheres::beyond`]'s (each its end's).
    pub(crate) fn parameters(&self) -> (&[f64], &[f64]) {
        self.us.split_at(self.tube_items)
    }

    /// Whether the ray from `eye` to `target` (whose pixel is `pixel`) enters the tube before
    /// it (beyond a tenth of a millimetre's slack).
    pub(crate) fn blocks(
        &self,
        eye: &Point3<f64>,
        target: &Point3<f64>,
        pixel: Vector2<f64>,
    ) -> bool {
        let to = target - eye;
        let depth = to.norm();
        let d = to / depth;
        self.grid.near(pixel).iter().any(|&i| {
            let (c, px, _) = &self.items[i as usize];
            if (px - pixel).norm_squared() > self.reach2[i as usize].1 {
                return false;
            }
            enters_before(c, self.radii[i as usize], eye, &d, depth - 0.1)
        })
    }

    fn hide(&self, eye: &Point3<f64>, p: &OutlinePoint) -> bool {
        let to = p.world - eye;
        let depth = to.norm();
        let d = to / depth;
        // From the outline out to the clearance, no other part of the tube may show: a part
        // behind whose edge lies even a fraction of a pixel beyond this one's merges with it in
        // the image and moves the boundary found (seen: 0.95 px, where a tip pointing at the
        // camera lay just beside the outline of the tube behind it). The tube's own spheres
        // here reach the outline and no farther, so none covers its point by a quarter pixel.
        // At the point itself, one pass over its cell also asks whether the ray enters the
        // tube before it; the points outward in that cell (most are) are asked in the same
        // pass, the others in their own cells.
        let cell = self.grid.cell(p.pixel);
        let outward = [0.75, 1.5, self.clearance].map(|step| {
            let q = p.pixel + p.normal * step;
            (q, self.grid.cell(q))
        });
        let covers =
            |i: usize, q: &Vector2<f64>| (self.items[i].1 - q).norm_squared() < self.reach2[i].0;
        let here = self.grid.members(cell).iter().any(|&i| {
            let i = i as usize;
            let (c, px, _) = &self.items[i];
            let (inner, outer) = self.reach2[i];
            let d2 = (px - p.pixel).norm_squared();
            d2 < inner
                || outward.iter().any(|(q, at)| *at == cell && covers(i, q))
                || (d2 <= outer && enters_before(c, self.radii[i], eye, &d, depth - 0.01))
        });
        here || outward.iter().any(|(q, at)| {
            *at != cell
                && self
                    .grid
                    .members(*at)
                    .iter()
                    .any(|&i| covers(i as usize, q))
        })
    }
}

/// Whether the ray from `eye` along the unit `d` enters the sphere about `c` of radius `r`
/// (not merely grazing it: within 0.98 `r` of its centre) before `depth`, mm.
fn enters_before(c: &Point3<f64>, r: f64, eye: &Point3<f64>, d: &Vector3<f64>, depth: f64) -> bool {
    let v = c - eye;
    let along = v.dot(d);
    // The entry is at least `along − r`: a sphere wholly behind is decided without roots.
    if along - r >= depth {
        return false;
    }
    let miss2 = (v.norm_squared() - along * along).max(0.0);
    miss2 < (0.98 * r).powi(2) && along - (r * r - miss2).sqrt() < depth
}

/// How far an open end's straight continuation is followed, mm: far enough to cover what
/// lies beside the fitted part in any view (a camera looking along it sees it shrink toward
/// its vanishing point and would follow it for ever).
pub(crate) const BEYOND_MM: f64 = 300.0;

/// A sphere as a camera sees it: centre (world), its pixel and its image radius in pixels.
pub(crate) type Projected = (Point3<f64>, Vector2<f64>, f64);

/// Spheres projected exactly at every this many along a row of centres, in between by
/// interpolation: over a few millimetres of centerline its image is straight to hundredths of
/// a pixel.
const PROJECTED_EVERY: usize = 4;

/// [`sphere`] of each of `centres` (centre, radius; evenly spaced along a smooth curve or a
/// line): every [`PROJECTED_EVERY`]-th and the last exactly, the ones between (of the same
/// radius as both neighbours) interpolated.
pub(crate) fn spheres_along(
    camera: &Camera,
    centres: &[(Point3<f64>, f64)],
) -> Vec<Option<Projected>> {
    let n = centres.len();
    let mut out: Vec<Option<Projected>> = vec![None; n];
    let knots: Vec<usize> = (0..n)
        .step_by(PROJECTED_EVERY)
        .chain((n > 0 && !(n - 1).is_multiple_of(PROJECTED_EVERY)).then_some(n - 1))
        .collect();
    for &k in &knots {
        out[k] = sphere(camera, centres[k].0, centres[k].1);
    }
    for pair in knots.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let ends = out[a]
            .zip(out[b])
            .filter(|_| centres[a..=b].iter().all(|c| c.1 == centres[a].1));
        for i in a + 1..b {
            out[i] = match ends {
                Some(((ca, pa, ra), (cb, pb, rb))) => {
                    // By where the centre lies between the two (centres evenly spaced in the
                    // curve's parameter are not quite evenly spaced along it).
                    let chord = cb - ca;
                    let t = ((centres[i].0 - ca).dot(&chord) / chord.norm_squared().max(1e-300))
                        .clamp(0.0, 1.0);
                    Some((centres[i].0, pa + (pb - pa) * t, ra + (rb - ra) * t))
                }
                None => sphere(camera, centres[i].0, centres[i].1),
            };
        }
    }
    out
}

/// A sphere's centre, pixel and image radius (the larger of two offsets of `r` across the ray,
/// through the projection's Jacobian at the centre: to first order in `r` over the distance,
/// a few thousandths of a pixel at the distances a tube is filmed from).
pub(crate) fn sphere(
    camera: &Camera,
    c: Point3<f64>,
    r: f64,
) -> Option<(Point3<f64>, Vector2<f64>, f64)> {
    let (proj, j) = camera.project_with_jacobian(&c).ok()?;
    let ray = (c - camera.centre()).normalize();
    let mut side = ray.cross(&Vector3::x());
    if side.norm() < 0.1 {
        side = ray.cross(&Vector3::y());
    }
    let side = side.normalize();
    let radius = (j * side).norm().max((j * ray.cross(&side)).norm()) * r;
    Some((c, proj.pixel.coords, radius))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use flexshape_camera::{Distortion, Intrinsics, Pose};
    use flexshape_curve::BSpline3;

    /// A 640×480 camera with strong distortion at `eye`, looking at the origin, z up.
    pub(crate) fn camera_at(eye: Point3<f64>) -> Camera {
        let intr = Intrinsics::new(
            640,
            480,
            800.0,
            805.0,
            322.0,
            236.0,
            Distortion::from_opencv(&[-0.2, 0.1, 0.001, -0.0005, -0.02]).unwrap(),
        )
        .unwrap();
        Camera::new(intr, Pose::look_at(eye, Point3::origin(), Vector3::z()))
    }

    fn camera() -> Camera {
        camera_at(Point3::new(40.0, -500.0, 120.0))
    }

    fn tube() -> Tube {
        let control = (0..8)
            .map(|i| {
                let t = i as f64;
                [8.0 * (t * 0.5).sin(), 4.0 * t, 20.0 * t - 70.0]
            })
            .collect();
        Tube {
            centerline: BSpline3::new(control).unwrap(),
            radius: 3.0,
            steps: Vec::new(),
            capped: [false, true],
        }
    }

    /// Smallest distance from `p` to the projection of the surface points around the circle
    /// of the centerline at `u` — the outline point must be the extreme one along its normal.
    #[test]
    fn outline_points_are_extreme_along_their_normals() {
        let cam = camera();
        let tube = tube();
        let pts = outline(&cam, &tube, &Sampled::new(&tube, 2.0), 2.0, 2.0);
        assert!(pts.len() > 60, "{}", pts.len());
        for p in pts.iter().filter(|p| matches!(p.part, Part::Side(_))) {
            let (c, t) = tube.frame(p.u);
            let e1 = t.cross(&Vector3::x()).normalize();
            let e2 = t.cross(&e1);
            let mut best = f64::NEG_INFINITY;
            for k in 0..3600 {
                let a = k as f64 / 3600.0 * std::f64::consts::TAU;
                let x = c + (e1 * a.cos() + e2 * a.sin()) * tube.radius;
                let q = cam.project(&x).unwrap().pixel.coords;
                best = best.max((q - p.pixel).dot(&p.normal));
            }
            assert!(best.abs() < 1e-3, "u {} overshoot {best}", p.u);
        }
    }

    /// A camera that sees a radius step obliquely, nearly along the tube, sees the thinner
    /// tube within the shoulder's image for many millimetres past the few that
    /// `Tube::at_shoulder` leaves out: no side point lies within the shoulder's image and the
    /// boundary search's reach of it, and the thinner tube beyond keeps its points.
    #[test]
    fn side_points_in_a_shoulders_image_are_left_out() {
        // A straight tube along z, 1 mm radius to 60 mm from its tip, 3 mm beyond; the camera
        // 25° off its axis, beyond the tip.
        let control = (0..8).map(|i| [0.0, 0.0, 20.0 * i as f64 - 70.0]).collect();
        let tube = Tube {
            centerline: BSpline3::new(control).unwrap(),
            radius: 1.0,
            steps: vec![flexshape_curve::RadiusStep {
                from_tip_mm: 60.0,
                radius_mm: 3.0,
            }],
            capped: [false, true],
        };
        let angle = 25f64.to_radians();
        let cam = camera_at(Point3::new(0.0, -400.0 * angle.sin(), 400.0 * angle.cos()));
        let sampled = Sampled::new(&tube, 1.0);
        let (shoulder, r) = sampled.shoulders[0];
        let (_, c, rp) = sphere(&cam, shoulder, r).unwrap();
        let pts = outline(&cam, &tube, &sampled, 1.0, 2.0);
        let thin: Vec<_> = pts
            .iter()
            .filter(|p| matches!(p.part, Part::Side(_)) && p.section == 0)
            .collect();
        let near = thin
            .iter()
            .filter(|p| (p.pixel - c).norm() < rp + SHOULDER_CLEARANCE_PX)
            .count();
        assert_eq!(near, 0, "{near} of {} thin side points", thin.len());
        assert!(thin.len() > 40, "{}", thin.len());
    }

    /// Interpolated spheres lie within hundredths of a pixel of projected ones, along the
    /// bent tube and across a radius step (where they are projected).
    #[test]
    fn spheres_between_projected_ones_are_where_projection_puts_them() {
        let cam = camera();
        let mut tube = tube();
        let length = tube.length();
        tube.steps = vec![flexshape_curve::RadiusStep {
            from_tip_mm: 0.4 * length,
            radius_mm: 4.0,
        }];
        let centres = sphere_centres(&tube, length);
        let along = spheres_along(&cam, &centres);
        assert_eq!(along.len(), centres.len());
        let mut worst = 0.0f64;
        for (got, &(c, r)) in along.iter().zip(&centres) {
            let (g, e) = (got.unwrap(), sphere(&cam, c, r).unwrap());
            worst = worst.max((g.1 - e.1).norm()).max((g.2 - e.2).abs());
        }
        assert!(worst < 0.05, "{worst} px");
    }

    /// Moving the centerline and radius moves the outline by `gain·(n·δC + δr)`.
    #[test]
    fn gain_predicts_how_the_outline_moves() {
        let cam = camera();
        let tube = tube();
        let pts = outline(&cam, &tube, &Sampled::new(&tube, 5.0), 5.0, 2.0);
        let delta = Vector3::new(0.03, -0.02, 0.025);
        let dr = 0.01;
        let mut moved = tube.clone();
        moved.radius += dr;
        let mut d = nalgebra::DVector::zeros(3 * moved.centerline.control().len());
        for i in 0..moved.centerline.control().len() {
            for c in 0..3 {
                d[3 * i + c] = delta[c];
            }
        }
        moved.centerline.displace(&d);
        let after = outline(&cam, &moved, &Sampled::new(&moved, 5.0), 5.0, 2.0);
        assert_eq!(pts.len(), after.len());
        for (a, b) in pts.iter().zip(&after) {
            let predicted = a.gain * (a.surface.dot(&delta) + dr);
            // The moved outline point lies on the moved outline; compare along the normal.
            let measured = (b.pixel - a.pixel).dot(&a.normal);
            assert!(
                (measured - predicted).abs() < 2e-3 * (1.0 + predicted.abs()),
                "{:?}: {measured} vs {predicted}",
                a.part
            );
        }
    }
}
