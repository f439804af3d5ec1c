//! OBJ import: one surface per OBJ object/group (split where the material changes), reflectance
//! from the MTL `Kd`, placed in the world frame (metres, z up).
//!
//! Haiko parses the statements it uses itself (docs/DECISIONS.md, "Scene"), so that no input
//! reaches a panic in a dependency and every error names the file and the line:
//! * OBJ: `v x y z` (optionally `w`, or an `r g b` vertex colour, which is ignored), `f` with
//!   `v`, `v/vt`, `v//vn` or `v/vt/vn` corners (1-based, negative = relative to the vertices
//!   read so far), `o` / `g` (a new surface), `usemtl`, `mtllib` (relative to the OBJ's
//!   directory). `vt`, `vn`, `l`, `p`, `s` and unknown statements are ignored.
//! * MTL: `newmtl` and `Kd r g b` (or `Kd r`, grey, as the MTL specification allows); every
//!   other statement (`Ka`, `Ks`, `Ke`, maps, …) is ignored.
//!
//! Placement: the up conversion first (`up = "y"`: (x, y, z) → (x, −z, y); `up = "z"`: kept),
//! then the uniform scale, then the translation. A surface without a material, or whose
//! material has no `Kd`, gets a grey reflectance of 0.5. Polygons are split into triangle fans.
//! Two repairs are made and reported as notes ([`ObjImport::notes`], docs/DECISIONS.md
//! "Degenerate and inside-out OBJ faces"): a face whose area is below 1e-12 m² (after
//! placement) is left out, and a closed solid whose faces all turn inwards is turned outwards.

use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::fsio::{self, FileKind};
use crate::scene::mesher::TriangleSurface;
use crate::scene::model::Reflectance;
use crate::scene::room_file::UpAxis;

/// Reflectance of OBJ surfaces without a material or without `Kd`.
pub(crate) const DEFAULT_REFLECTANCE: f64 = 0.5;

/// Faces smaller than this (m², after placement) are left out as degenerate.
pub(crate) const MIN_FACE_AREA: f64 = 1e-12;

/// The most triangles (after splitting polygons into fans) one OBJ may have. The fine mesh
/// needs up to three vertices per OBJ triangle at any patch size, so this keeps an OBJ within the
/// room's 2 000 000-vertex limit (`crate::scene::load::MAX_VERTICES`) with room to spare.
pub(crate) const MAX_TRIANGLES: usize = 600_000;

/// The most vertices (`v` lines) one OBJ may have.
pub(crate) const MAX_VERTICES: usize = 2_000_000;

/// Where an OBJ goes in the room.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The OBJ's up axis.
    pub up: UpAxis,
    /// Uniform scale (> 0), applied after the up conversion.
    pub scale: f64,
    /// Translation (world, m), applied last.
    pub translate: DVec3,
}

impl Placement {
    /// The world position (m) of an OBJ point.
    pub fn apply(&self, p: DVec3) -> DVec3 {
        let z_up = match self.up {
            UpAxis::Y => DVec3::new(p.x, -p.z, p.y),
            UpAxis::Z => p,
        };
        z_up * self.scale + self.translate
    }
}

/// A placed OBJ surface and its reflectance.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjSurface {
    /// The triangles, world frame.
    pub geometry: TriangleSurface,
    /// From the MTL `Kd`.
    pub reflectance: Reflectance,
}

/// What an OBJ gives the room: its surfaces, and what the import repaired on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjImport {
    /// The placed surfaces (an object whose every face was left out has none).
    pub surfaces: Vec<ObjSurface>,
    /// One sentence per repair, naming the file, the faces (numbers and lines) or the object:
    /// degenerate faces left out, closed solids turned outwards.
    pub notes: Vec<String>,
}

/// Reads the OBJ at `path` for `[[mesh]]` number `mesh_index`, and its material libraries,
/// through [`crate::fsio`]. Errors name the OBJ or MTL file and the line.
pub fn read_obj(path: &Path, mesh_index: usize, placement: &Placement) -> Result<ObjImport> {
    let bytes = fsio::read(path, FileKind::Obj)?;
    parse_obj(path, &bytes, mesh_index, placement, &|mtl| {
        fsio::read(mtl, FileKind::Mtl)
    })
}

/// Parses OBJ bytes (UTF-8; invalid bytes only matter inside names) as read from `path` (used
/// for errors and to resolve `mtllib`); `read_mtl` reads a material library at its resolved path.
pub fn parse_obj(
    path: &Path,
    bytes: &[u8],
    mesh_index: usize,
    placement: &Placement,
    read_mtl: &dyn Fn(&Path) -> Result<Vec<u8>>,
) -> Result<ObjImport> {
    let text = String::from_utf8_lossy(bytes);
    let parsed = Statements::parse(path, &text, read_mtl)?;
    let mut surfaces = Vec::with_capacity(parsed.groups.len());
    let mut names: Vec<String> = Vec::new();
    let mut degenerate: Vec<&Face> = Vec::new();
    // Per surface, the OBJ object (group) it came from.
    let mut objects: Vec<&str> = Vec::new();
    let mut notes = Vec::new();
    let file = path.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
    for group in &parsed.groups {
        let material = group.material.map(|m| &parsed.materials[m]);
        let reflectance = material_reflectance(path, material)?;
        let Placed {
            positions,
            triangles,
            left_out,
        } = parsed.place(path, group, placement)?;
        degenerate.extend(left_out);
        if triangles.is_empty() {
            continue;
        }
        let mut name = format!("mesh{mesh_index}:{}", group.name);
        if names.contains(&name) {
            name = format!("{name}#{}", surfaces.len());
        }
        names.push(name.clone());
        surfaces.push(ObjSurface {
            geometry: TriangleSurface {
                name,
                mesh_index,
                positions,
                triangles,
            },
            reflectance,
        });
        objects.push(group.name.as_str());
    }
    if !degenerate.is_empty() {
        notes.push(format!(
            "OBJ `{file}`: {} degenerate face{} (area below {MIN_FACE_AREA:e} m² after placement) \
             left out: {}",
            degenerate.len(),
            plural(degenerate.len()),
            listed(
                degenerate
                    .iter()
                    .map(|f| format!("face {} (line {})", f.number, f.line))
            )
        ));
    }
    let (turned, touched) = turn_closed_solids_outwards(&mut surfaces);
    if turned > 0 {
        let mut named: Vec<&str> = Vec::new();
        for &k in &touched {
            if !named.contains(&objects[k]) {
                named.push(objects[k]);
            }
        }
        notes.push(format!(
            "OBJ `{file}`: {turned} closed solid{} whose faces all turned into the solid instead \
             of out of it turned round (object{} {})",
            plural(turned),
            plural(named.len()),
            listed(named.iter().map(|n| format!("`{n}`")))
        ));
    }
    Ok(ObjImport { surfaces, notes })
}

/// "s" unless `n` is 1.
fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// The first three of `items` joined with ", ", then how many more there are.
fn listed(items: impl ExactSizeIterator<Item = String>) -> String {
    let total = items.len();
    let shown: Vec<String> = items.take(3).collect();
    match total - shown.len() {
        0 => shown.join(", "),
        more => format!("{} and {more} more", shown.join(", ")),
    }
}

/// A material of an MTL file.
#[derive(Debug, Clone)]
struct Material {
    name: String,
    /// `Kd` and the MTL file and line it was on.
    diffuse: Option<([f64; 3], PathBuf, usize)>,
}

/// One polygon of the OBJ: 0-based vertex indices and its 1-based face number and line.
#[derive(Debug, Clone)]
struct Face {
    vertices: Vec<usize>,
    number: usize,
    line: usize,
}

/// The faces of one object/group with one material.
#[derive(Debug, Clone)]
struct Group {
    name: String,
    material: Option<usize>,
    faces: Vec<Face>,
}

/// A group placed in the world ([`Statements::place`]).
struct Placed<'g> {
    /// The vertices its faces use (world, m).
    positions: Vec<DVec3>,
    /// Its triangles, indices into `positions`.
    triangles: Vec<[u32; 3]>,
    /// Its faces left out as degenerate.
    left_out: Vec<&'g Face>,
}

/// The statements of an OBJ file Haiko uses.
#[derive(Debug, Default)]
struct Statements {
    /// `v` positions as written (OBJ frame).
    positions: Vec<DVec3>,
    /// Groups with at least one face, in file order.
    groups: Vec<Group>,
    /// Materials of all `mtllib`s, in order; a later one of the same name wins in `by_name`.
    materials: Vec<Material>,
    by_name: HashMap<String, usize>,
    /// Triangles the faces will make (for the limit).
    triangles: usize,
    /// Faces read so far.
    n_faces: usize,
}

/// An error at `line` of `file`.
fn at(file: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::input(file, format!("line {line}"), message)
}

/// A finite number, or `None`.
fn finite(token: &str) -> Option<f64> {
    token.parse::<f64>().ok().filter(|x| x.is_finite())
}

/// The rest of a statement line after its keyword, trimmed (names may contain spaces).
fn rest_of<'a>(line: &'a str, keyword: &str) -> &'a str {
    line.trim_start()[keyword.len()..].trim()
}

impl Statements {
    fn parse(path: &Path, text: &str, read_mtl: &dyn Fn(&Path) -> Result<Vec<u8>>) -> Result<Self> {
        let mut s = Statements::default();
        let mut current = Group {
            name: "unnamed_object".into(),
            material: None,
            faces: Vec::new(),
        };
        for (index, line) in text.lines().enumerate() {
            let n = index + 1;
            let mut words = line.split_whitespace();
            let Some(keyword) = words.next() else { continue };
            match keyword {
                "v" => s.vertex(path, n, words)?,
                "f" => {
                    let face = s.face(path, n, words)?;
                    current.faces.push(face);
                }
                "o" | "g" => {
                    let name = rest_of(line, keyword);
                    let name = if name.is_empty() { "unnamed_object" } else { name };
                    let material = current.material;
                    s.close(&mut current, name.to_string(), material);
                }
                "usemtl" => {
                    let name = rest_of(line, keyword);
                    if name.is_empty() {
                        return Err(at(path, n, "`usemtl` needs a material name"));
                    }
                    let material = s.by_name.get(name).copied();
                    if material != current.material {
                        let name = current.name.clone();
                        s.close(&mut current, name, material);
                    }
                }
                "mtllib" => {
                    let name = rest_of(line, keyword);
                    if name.is_empty() {
                        return Err(at(path, n, "`mtllib` needs a file name"));
                    }
                    let mtl = path.parent().unwrap_or(Path::new("")).join(name);
                    let bytes = read_mtl(&mtl)?;
                    s.materials(&mtl, &String::from_utf8_lossy(&bytes))?;
                }
                _ => {}
            }
        }
        s.close(&mut current, String::new(), None);
        for group in &s.groups {
            for face in &group.faces {
                if let Some(&v) = face.vertices.iter().find(|&&v| v >= s.positions.len()) {
                    return Err(at(
                        path,
                        face.line,
                        format!(
                            "face {} refers to vertex {}, but the file has {} vertices",
                            face.number,
                            v + 1,
                            s.positions.len()
                        ),
                    ));
                }
            }
        }
        Ok(s)
    }

    /// Ends the current group (kept when it has faces) and starts `name` with `material`.
    fn close(&mut self, current: &mut Group, name: String, material: Option<usize>) {
        let next = Group {
            name,
            material,
            faces: Vec::new(),
        };
        let done = std::mem::replace(current, next);
        if !done.faces.is_empty() {
            self.groups.push(done);
        }
    }

    /// `v x y z [w | r g b]`.
    fn vertex<'a>(&mut self, path: &Path, n: usize, words: impl Iterator<Item = &'a str>) -> Result<()> {
        let values: Vec<Option<f64>> = words.map(finite).collect();
        let usage = "`v` needs three finite numbers x y z (optionally w, or r g b)";
        let Some(values) = values.into_iter().collect::<Option<Vec<f64>>>() else {
            return Err(at(path, n, usage));
        };
        let p = match values.as_slice() {
            [x, y, z] | [x, y, z, _, _, _] => DVec3::new(*x, *y, *z),
            [x, y, z, w] if *w != 0.0 => DVec3::new(*x, *y, *z) / *w,
            [_, _, _, _] => return Err(at(path, n, "`v` has w = 0 (a point at infinity)")),
            _ => return Err(at(path, n, usage)),
        };
        if !p.is_finite() {
            return Err(at(path, n, "the vertex is not finite after dividing by w"));
        }
        if self.positions.len() == MAX_VERTICES {
            return Err(at(
                path,
                n,
                format!("more than {MAX_VERTICES} vertices: simplify the OBJ"),
            ));
        }
        self.positions.push(p);
        Ok(())
    }

    /// `f v1 v2 v3 …`, each corner `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    fn face<'a>(&mut self, path: &Path, n: usize, words: impl Iterator<Item = &'a str>) -> Result<Face> {
        self.n_faces += 1;
        let number = self.n_faces;
        let mut vertices = Vec::new();
        for corner in words {
            let mut parts = corner.split('/');
            let v = parts.next().unwrap_or_default();
            let others_ok =
                parts.clone().count() <= 2 && parts.all(|p| p.is_empty() || p.parse::<i64>().is_ok());
            let index = v.parse::<i64>().ok().filter(|_| others_ok).ok_or_else(|| {
                at(
                    path,
                    n,
                    format!("face {number}: a corner must be v, v/vt, v//vn or v/vt/vn with whole numbers"),
                )
            })?;
            let resolved = match index {
                0 => {
                    return Err(at(
                        path,
                        n,
                        format!("face {number}: vertex index 0 (OBJ counts from 1)"),
                    ));
                }
                i if i > 0 => usize::try_from(i - 1).ok(),
                i => usize::try_from(i.unsigned_abs())
                    .ok()
                    .and_then(|back| self.positions.len().checked_sub(back)),
            };
            let Some(resolved) = resolved else {
                return Err(at(
                    path,
                    n,
                    format!(
                        "face {number}: relative index {index} goes before the first vertex ({} read so far)",
                        self.positions.len()
                    ),
                ));
            };
            vertices.push(resolved);
        }
        if vertices.len() < 3 {
            return Err(at(
                path,
                n,
                format!(
                    "face {number} has {} corners; a face needs at least 3",
                    vertices.len()
                ),
            ));
        }
        self.triangles += vertices.len() - 2;
        if self.triangles > MAX_TRIANGLES {
            return Err(at(
                path,
                n,
                format!(
                    "the OBJ has more than {MAX_TRIANGLES} triangles (polygons split into fans); the \
                     room's mesh needs up to 3 vertices per triangle at any patch size: simplify the OBJ"
                ),
            ));
        }
        Ok(Face {
            vertices,
            number,
            line: n,
        })
    }

    /// Reads the materials of the MTL text at `path`.
    fn materials(&mut self, path: &Path, text: &str) -> Result<()> {
        let mut current: Option<Material> = None;
        for (index, line) in text.lines().enumerate() {
            let n = index + 1;
            let mut words = line.split_whitespace();
            match words.next() {
                Some("newmtl") => {
                    let name = rest_of(line, "newmtl");
                    if name.is_empty() {
                        return Err(at(path, n, "`newmtl` needs a material name"));
                    }
                    self.add_material(current.take());
                    current = Some(Material {
                        name: name.to_string(),
                        diffuse: None,
                    });
                }
                Some("Kd") => {
                    let values: Option<Vec<f64>> = words.map(finite).collect();
                    let rgb = match values.as_deref() {
                        Some(&[grey]) => [grey; 3],
                        Some(&[r, g, b]) => [r, g, b],
                        _ => {
                            return Err(at(
                                path,
                                n,
                                "`Kd` needs three finite numbers r g b (or one, for grey)",
                            ));
                        }
                    };
                    if let Some(material) = current.as_mut() {
                        material.diffuse = Some((rgb, path.to_path_buf(), n));
                    }
                }
                _ => {}
            }
        }
        self.add_material(current);
        Ok(())
    }

    fn add_material(&mut self, material: Option<Material>) {
        if let Some(material) = material {
            self.by_name.insert(material.name.clone(), self.materials.len());
            self.materials.push(material);
        }
    }

    /// The group's vertices placed in the world (only those its kept faces use), its triangles
    /// ([`triangulate`]; triangles below [`MIN_FACE_AREA`] dropped) and the faces left out
    /// because their area, or every triangle of theirs, is below it; a face whose area is not
    /// finite is an error.
    fn place<'g>(&self, path: &Path, group: &'g Group, placement: &Placement) -> Result<Placed<'g>> {
        let mut local: HashMap<usize, u32> = HashMap::new();
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        let mut left_out = Vec::new();
        for face in &group.faces {
            // Vertices first used by this face, taken back if it is left out: a dropped face's
            // corners must not widen the mesh's bounds.
            let (kept, mut added) = (positions.len(), Vec::new());
            let ids: Vec<u32> = face
                .vertices
                .iter()
                .map(|&v| {
                    *local.entry(v).or_insert_with(|| {
                        added.push(v);
                        positions.push(placement.apply(self.positions[v]));
                        positions.len() as u32 - 1
                    })
                })
                .collect();
            let pieces = triangulate(&positions, &ids);
            let area = |t: &[u32; 3]| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            };
            let face_area: f64 = pieces.iter().map(area).sum();
            if !face_area.is_finite() {
                return Err(at(
                    path,
                    face.line,
                    format!(
                        "face {} (object `{}`): its area is not finite after placement (scale it down)",
                        face.number, group.name
                    ),
                ));
            }
            let whole: Vec<[u32; 3]> = pieces.into_iter().filter(|t| area(t) >= MIN_FACE_AREA).collect();
            if face_area < MIN_FACE_AREA || whole.is_empty() {
                left_out.push(face);
                positions.truncate(kept);
                added.iter().for_each(|v| {
                    local.remove(v);
                });
                continue;
            }
            triangles.extend(whole);
        }
        Ok(Placed {
            positions,
            triangles,
            left_out,
        })
    }
}

/// The triangles of the polygon `ids` (indices into `positions`, in the face's order): a fan
/// from its first corner when the polygon is convex (or not planar enough to tell), else ear
/// clipping, so an L-shaped face (a sofa's seat) is covered once and facing one way
/// (docs/DECISIONS.md "Non-convex OBJ faces"). Every triangle keeps the face's winding.
fn triangulate(positions: &[DVec3], ids: &[u32]) -> Vec<[u32; 3]> {
    let fan =
        |ids: &[u32]| -> Vec<[u32; 3]> { (2..ids.len()).map(|c| [ids[0], ids[c - 1], ids[c]]).collect() };
    let at = |i: u32| positions[i as usize];
    // Newell's normal: the polygon's area vector, whatever its shape.
    let normal = (0..ids.len()).fold(DVec3::ZERO, |n, k| {
        let (a, b) = (at(ids[k]), at(ids[(k + 1) % ids.len()]));
        n + a.cross(b)
    });
    let turn = |a: u32, b: u32, c: u32| (at(b) - at(a)).cross(at(c) - at(b)).dot(normal);
    let n = ids.len();
    if n <= 3
        || normal.length_squared() == 0.0
        || (0..n).all(|k| turn(ids[k], ids[(k + 1) % n], ids[(k + 2) % n]) >= 0.0)
    {
        return fan(ids);
    }
    let inside = |p: DVec3, [a, b, c]: [u32; 3]| {
        let side = |u: u32, v: u32| (at(v) - at(u)).cross(p - at(u)).dot(normal) >= 0.0;
        side(a, b) && side(b, c) && side(c, a)
    };
    let mut rest = ids.to_vec();
    let mut out = Vec::with_capacity(n - 2);
    while rest.len() > 3 {
        let m = rest.len();
        let ear = (0..m).find(|&k| {
            let t = [rest[(k + m - 1) % m], rest[k], rest[(k + 1) % m]];
            turn(t[0], t[1], t[2]) > 0.0
                && rest
                    .iter()
                    .filter(|i| !t.contains(i))
                    .all(|&i| at(i) == at(t[0]) || at(i) == at(t[2]) || !inside(at(i), t))
        });
        // A self-crossing polygon has no ear: what is left is fanned.
        let Some(k) = ear else {
            out.extend(fan(&rest));
            return out;
        };
        out.push([rest[(k + m - 1) % m], rest[k], rest[(k + 1) % m]]);
        rest.remove(k);
    }
    out.push([rest[0], rest[1], rest[2]]);
    out
}

/// `Kd` as a reflectance; 0.5 grey without a material or `Kd`.
fn material_reflectance(obj: &Path, material: Option<&Material>) -> Result<Reflectance> {
    let Some((kd, mtl, line)) = material.and_then(|m| m.diffuse.as_ref()) else {
        return Ok(Reflectance::grey(DEFAULT_REFLECTANCE));
    };
    if kd.iter().any(|k| !(0.0..0.98).contains(k)) {
        let name = material.map_or("", |m| m.name.as_str());
        return Err(Error::input(
            mtl,
            format!("line {line}"),
            format!(
                "material `{name}` (used by {}): Kd {kd:?} must be ≥ 0 and below 0.98 (the \
                 interreflection becomes singular as reflectance approaches 1)",
                obj.file_name().map(|n| n.to_string_lossy()).unwrap_or_default()
            ),
        ));
    }
    Ok(Reflectance(*kd))
}

/// Turns round each closed shell among the surfaces' triangles whose faces turn into the solid
/// instead of out of it; returns how many shells it turned and the surfaces it changed
/// (docs/DECISIONS.md "Degenerate and inside-out OBJ faces"). A shell is a set of triangles
/// joined edge to edge (corners compared exactly, so faces that do not share vertex indices, or
/// lie in different objects or materials, join too) in which every edge is met exactly once each
/// way: closed and consistently turned. Its signed volume `Σ a·(b×c) / 6` is positive when its
/// faces turn out of what it encloses. A shell inside an odd number of other shells bounds a
/// hollow (the inside of a vase), whose faces turn into the hollow: negative. A shell whose sign
/// is the other one is turned round. No light can reach the faces of a wrongly turned shell:
/// lights are never inside a mesh's material. Open meshes, shells meeting along an edge of three
/// or more faces, and a two-sided sheet (volume zero) are left as they are.
fn turn_closed_solids_outwards(surfaces: &mut [ObjSurface]) -> (usize, Vec<usize>) {
    // Every triangle: its surface and index there, and its corners welded by position.
    let mut welded: HashMap<[u64; 3], u32> = HashMap::new();
    let mut owner: Vec<(usize, usize)> = Vec::new();
    let mut corners: Vec<[u32; 3]> = Vec::new();
    for (k, surface) in surfaces.iter().enumerate() {
        let g = &surface.geometry;
        for (t, triangle) in g.triangles.iter().enumerate() {
            owner.push((k, t));
            corners.push(triangle.map(|i| {
                let next = welded.len() as u32;
                *welded.entry(exact_key(g.positions[i as usize])).or_insert(next)
            }));
        }
    }
    let Some(origin) = surfaces
        .iter()
        .find_map(|s| s.geometry.positions.first().copied())
    else {
        return (0, Vec::new());
    };
    let at = |t: usize| {
        let (k, i) = owner[t];
        let g = &surfaces[k].geometry;
        g.triangles[i].map(|v| g.positions[v as usize])
    };
    // Per directed edge: how many triangles have it, and the first.
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for (t, c) in corners.iter().enumerate() {
        for k in 0..3 {
            let e = edges.entry((c[k], c[(k + 1) % 3])).or_insert((0, t as u32));
            e.0 += 1;
        }
    }
    let mut parent: Vec<usize> = (0..corners.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut closed = vec![true; corners.len()];
    for (t, c) in corners.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            match (edges[&(a, b)], edges.get(&(b, a))) {
                ((1, _), Some(&(1, other))) => {
                    let (x, y) = (root(&mut parent, t), root(&mut parent, other as usize));
                    parent[x] = y;
                }
                _ => closed[t] = false,
            }
        }
    }
    // Per shell: its triangles, whether closed, its signed volume ×6 and that sum's scale
    // Σ |a·(b×c)| (about `origin`), and its bounds.
    struct Shell {
        triangles: Vec<usize>,
        closed: bool,
        volume: f64,
        scale: f64,
        min: DVec3,
        max: DVec3,
    }
    let mut shells: Vec<Shell> = Vec::new();
    let mut shell_of: HashMap<usize, usize> = HashMap::new();
    for t in 0..corners.len() {
        let r = root(&mut parent, t);
        let s = *shell_of.entry(r).or_insert_with(|| {
            shells.push(Shell {
                triangles: Vec::new(),
                closed: true,
                volume: 0.0,
                scale: 0.0,
                min: DVec3::INFINITY,
                max: DVec3::NEG_INFINITY,
            });
            shells.len() - 1
        });
        let [a, b, c] = at(t);
        let v = (a - origin).dot((b - origin).cross(c - origin));
        let shell = &mut shells[s];
        shell.triangles.push(t);
        shell.closed &= closed[t];
        shell.volume += v;
        shell.scale += v.abs();
        shell.min = shell.min.min(a).min(b).min(c);
        shell.max = shell.max.max(a).max(b).max(c);
    }
    let solid: Vec<usize> = (0..shells.len())
        .filter(|&s| shells[s].closed && shells[s].volume.abs() > 1e-9 * shells[s].scale)
        .collect();
    let wrong: Vec<usize> = solid
        .iter()
        .copied()
        .filter(|&s| {
            let [a, b, c] = at(shells[s].triangles[0]);
            let p = (a + b + c) / 3.0;
            let depth = solid
                .iter()
                .filter(|&&o| {
                    let shell = &shells[o];
                    o != s
                        && p.cmpge(shell.min).all()
                        && p.cmple(shell.max).all()
                        && winding_number(p, shell.triangles.iter().map(|&t| at(t))).abs() > 0.5
                })
                .count();
            (shells[s].volume < 0.0) != (depth % 2 == 1)
        })
        .collect();
    let mut changed = vec![false; surfaces.len()];
    for &s in &wrong {
        for &t in &shells[s].triangles {
            let (k, i) = owner[t];
            surfaces[k].geometry.triangles[i].swap(1, 2);
            changed[k] = true;
        }
    }
    (wrong.len(), (0..surfaces.len()).filter(|&k| changed[k]).collect())
}

/// A point's coordinates bit for bit, −0 as +0: equal keys are the same point exactly.
fn exact_key(p: DVec3) -> [u64; 3] {
    (p + DVec3::ZERO).to_array().map(f64::to_bits)
}

/// The first triangle that appears twice facing the same way among `surfaces` (world frame):
/// the `[[mesh]]` indices of its first and second appearance and its corners (m). Coincident
/// faces each reflect the light the other also reflects, so their interreflection has no
/// bounded solution (docs/DECISIONS.md "Coincident OBJ faces"). Corners are compared exactly:
/// a mesh listed twice, or a face written twice, repeats them bit for bit. The same face facing
/// the other way (a two-sided sheet) is not a repeat.
pub fn first_repeated_triangle(surfaces: &[ObjSurface]) -> Option<(usize, usize, [DVec3; 3])> {
    let mut seen: HashMap<[[u64; 3]; 3], usize> = HashMap::new();
    for surface in surfaces {
        let g = &surface.geometry;
        for triangle in &g.triangles {
            let corners = triangle.map(|i| g.positions[i as usize]);
            // The rotation starting at the smallest corner keeps the turn of the triangle and so
            // the side it faces.
            let bits = corners.map(exact_key);
            let first = (0..3).min_by_key(|&k| bits[k]).unwrap_or(0);
            let key = [bits[first], bits[(first + 1) % 3], bits[(first + 2) % 3]];
            if let Some(&earlier) = seen.get(&key) {
                return Some((earlier, g.mesh_index, corners));
            }
            seen.insert(key, g.mesh_index);
        }
    }
    None
}

/// The generalized winding number of the triangles around `p` (Jacobson et al. 2013):
/// `Σ Ω / 4π` over their signed solid angles seen from `p`; ±1 inside a closed mesh (the sign
/// from its faces' turn), 0 outside, between for an open one.
pub fn winding_number(p: DVec3, triangles: impl Iterator<Item = [DVec3; 3]>) -> f64 {
    triangles
        .map(|[a, b, c]| signed_solid_angle(a - p, b - p, c - p))
        .sum::<f64>()
        / (4.0 * std::f64::consts::PI)
}

/// Signed solid angle (sr) of the triangle `a, b, c` seen from the origin, positive when it
/// turns counter-clockwise seen from there (Van Oosterom & Strackee 1983).
pub fn signed_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * numerator.atan2(denominator)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEEP: Placement = Placement {
        up: UpAxis::Z,
        scale: 1.0,
        translate: DVec3::ZERO,
    };

    fn import(obj: &str, mtl: &str) -> Result<ObjImport> {
        let mtl = mtl.as_bytes().to_vec();
        parse_obj(Path::new("d/m.obj"), obj.as_bytes(), 0, &KEEP, &move |p| {
            assert_eq!(p, Path::new("d/m.mtl"));
            Ok(mtl.clone())
        })
    }

    fn parse(obj: &str, mtl: &str) -> Result<Vec<ObjSurface>> {
        import(obj, mtl).map(|i| i.surfaces)
    }

    const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

    /// The triangles of a unit cube at `at`, counter-clockwise seen from outside (or reversed),
    /// each with its own three corners when `unwelded`; with or without its bottom.
    fn cube(at: DVec3, reverse: bool, unwelded: bool, bottom: bool) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let corner = |i: u32| at + DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64);
        let quads: &[[u32; 4]] = &[
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [1, 3, 7, 5],
            [3, 2, 6, 7],
            [2, 0, 4, 6],
        ];
        let mut positions: Vec<DVec3> = (0..8).map(corner).collect();
        let mut triangles = Vec::new();
        for q in &quads[usize::from(!bottom)..] {
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                let t = if reverse { [t[0], t[2], t[1]] } else { t };
                if unwelded {
                    let base = positions.len() as u32;
                    positions.extend(t.map(corner));
                    triangles.push([base, base + 1, base + 2]);
                } else {
                    triangles.push(t);
                }
            }
        }
        (positions, triangles)
    }

    /// [`turn_closed_solids_outwards`] on one surface of these triangles.
    fn turn(positions: &[DVec3], triangles: &mut Vec<[u32; 3]>) -> usize {
        let mut surfaces = [ObjSurface {
            geometry: TriangleSurface {
                name: "mesh0:test".into(),
                mesh_index: 0,
                positions: positions.to_vec(),
                triangles: triangles.clone(),
            },
            reflectance: Reflectance::grey(0.5),
        }];
        let (turned, touched) = turn_closed_solids_outwards(&mut surfaces);
        assert_eq!(touched, if turned > 0 { vec![0] } else { vec![] });
        *triangles = surfaces[0].geometry.triangles.clone();
        turned
    }

    fn volume(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
        triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn closed_solids_wound_inside_out_are_turned_and_nothing_else() {
        let at = DVec3::new(2.0, 3.0, 0.5);
        for unwelded in [false, true] {
            let (p, right) = cube(at, false, unwelded, true);
            assert!((volume(&p, &right) - 1.0).abs() < 1e-12);
            let mut t = right.clone();
            assert_eq!(turn(&p, &mut t), 0);
            assert_eq!(t, right);
            let (p, mut t) = cube(at, true, unwelded, true);
            assert_eq!(turn(&p, &mut t), 1, "unwelded {unwelded}");
            assert!((volume(&p, &t) - 1.0).abs() < 1e-12);
            // Open (no bottom, as furniture standing on the floor is often modelled): which
            // side is outside cannot be told, so it stays as written.
            let (p, wound) = cube(at, true, unwelded, false);
            let mut t = wound.clone();
            assert_eq!(turn(&p, &mut t), 0);
            assert_eq!(t, wound);
        }
        // Two cubes in one object, the second inside out: only it is turned.
        let (mut p, mut t) = cube(DVec3::ZERO, false, false, true);
        let (q, u) = cube(DVec3::new(3.0, 0.0, 0.0), true, false, true);
        let offset = p.len() as u32;
        p.extend(q);
        t.extend(u.iter().map(|tri| tri.map(|i| i + offset)));
        let first = t[..12].to_vec();
        assert_eq!(turn(&p, &mut t), 1);
        assert_eq!(t[..12], first[..]);
        assert!((volume(&p, &t) - 2.0).abs() < 1e-12);
        // A cube wound inside out whose top is another object (another material): one solid,
        // both objects turned, one note naming them.
        let corners = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n";
        let obj = format!(
            "{corners}o top\nf 5 7 8 6\no sides\nf 1 2 4 3\nf 1 5 6 2\nf 2 6 8 4\nf 4 8 7 3\nf 3 7 5 1\n"
        );
        let import = import(&obj, "").unwrap();
        assert_eq!(
            import.notes,
            [
                "OBJ `m.obj`: 1 closed solid whose faces all turned into the solid instead of out \
              of it turned round (objects `top`, `sides`)"
            ]
        );
        let total: f64 = import
            .surfaces
            .iter()
            .map(|s| volume(&s.geometry.positions, &s.geometry.triangles))
            .sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        // A hollow cube (a 3 m shell round a 1 m hollow, whose faces turn into the hollow):
        // right as it is; wound inside out as a whole, both shells turned; only its outer
        // shell wrong, only that one.
        let hollow = |outer_reversed: bool, inner_reversed: bool| {
            let (mut p, mut t) = cube(DVec3::ZERO, outer_reversed, false, true);
            p.iter_mut().for_each(|v| *v *= 3.0);
            let (q, u) = cube(DVec3::ONE, !inner_reversed, false, true);
            let offset = p.len() as u32;
            p.extend(q);
            t.extend(u.iter().map(|tri| tri.map(|i| i + offset)));
            (p, t)
        };
        for (outer, inner, turned) in [(false, false, 0), (true, true, 2), (true, false, 1)] {
            let (p, mut t) = hollow(outer, inner);
            assert_eq!(turn(&p, &mut t), turned, "outer {outer}, inner {inner}");
            assert_eq!(t, hollow(false, false).1, "outer {outer}, inner {inner}");
            assert!((volume(&p, &t) - 26.0).abs() < 1e-9);
        }
        // A two-sided sheet (each triangle both ways) encloses nothing: kept.
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        let mut t = vec![[0, 1, 2], [0, 2, 1]];
        assert_eq!(turn(&p, &mut t), 0);
        assert_eq!(t, [[0, 1, 2], [0, 2, 1]]);
    }

    #[test]
    fn a_face_written_twice_the_same_way_is_found_but_a_two_sided_sheet_is_not() {
        let two_sided = parse(&format!("{SQUARE}f 1 2 3\nf 3 2 1\n"), "").unwrap();
        assert_eq!(first_repeated_triangle(&two_sided), None);
        // The copy starts at another corner but turns the same way.
        let twice = parse(&format!("{SQUARE}f 1 2 3 4\nf 2 3 1\n"), "").unwrap();
        let corners = [DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.0), DVec3::ZERO];
        assert_eq!(first_repeated_triangle(&twice), Some((0, 0, corners)));
        // A mesh listed twice.
        let mut meshes = parse(&format!("{SQUARE}f 1 2 3\n"), "").unwrap();
        let mut copy = meshes.clone();
        copy[0].geometry.mesh_index = 1;
        meshes.extend(copy);
        assert_eq!(
            first_repeated_triangle(&meshes),
            Some((0, 1, [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)]))
        );
    }

    #[test]
    fn polygons_become_fans_and_relative_indices_count_back() {
        let s = parse(&format!("{SQUARE}f -4/1 -3//2 -2/3/4 -1\n"), "").unwrap();
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].geometry.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(s[0].geometry.name, "mesh0:unnamed_object");
    }

    /// An L-shaped face, listed from a corner its fan would not see all of: ear clipping covers
    /// the L once (the triangles' areas add up to its 3 m², none facing the other way), where
    /// the fan from its first corner overlaps itself and leaves the L.
    #[test]
    fn a_non_convex_face_is_covered_once_and_facing_one_way() {
        // The L: a 2 × 1 bar along x, a 1 × 1 block on its left end above; listed from (0, 2),
        // whose fan would pass outside the L to (2, 1).
        let obj = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 6 1 2 3 4 5\n";
        let s = parse(obj, "").unwrap();
        let g = &s[0].geometry;
        let area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| g.positions[i as usize]);
            (b - a).cross(c - a).z / 2.0
        };
        assert_eq!(g.triangles.len(), 4);
        assert!(g.triangles.iter().all(|t| area(t) > 0.0), "{:?}", g.triangles);
        let total: f64 = g.triangles.iter().map(area).sum();
        assert!((total - 3.0).abs() < 1e-12, "{total}");
        // Every triangle's centroid lies in the L.
        for t in &g.triangles {
            let c = t.iter().map(|&i| g.positions[i as usize]).sum::<DVec3>() / 3.0;
            assert!(c.x < 1.0 || c.y < 1.0, "a triangle outside the L at {c}");
        }
    }

    #[test]
    fn short_colour_lines_are_errors_or_grey_never_panics() {
        let obj = format!("mtllib m.mtl\n{SQUARE}usemtl a\nf 1 2 3\n");
        let grey = parse(&obj, "newmtl a\nKd 0.4\n").unwrap();
        assert_eq!(grey[0].reflectance, Reflectance::grey(0.4));
        for bad in ["Kd", "Kd 0.5 0.5", "Kd 0.5 x 0.5", "Kd 1 2 3 4", "Kd nan"] {
            let e = parse(&obj, &format!("newmtl a\n{bad}\n"))
                .unwrap_err()
                .to_string();
            assert_eq!(
                e,
                "d/m.mtl: line 2: `Kd` needs three finite numbers r g b (or one, for grey)"
            );
        }
        for ignored in ["Ka", "Ks 0.5", "Ke 0.5 0.5", "Ka spectral x.rfl"] {
            let s = parse(&obj, &format!("newmtl a\n{ignored}\nKd 0.2 0.3 0.4\n")).unwrap();
            assert_eq!(s[0].reflectance, Reflectance([0.2, 0.3, 0.4]));
        }
    }

    #[test]
    fn bad_statements_name_the_line() {
        for (obj, line, words) in [
            ("v 1 2\n", 1, "`v` needs three finite numbers"),
            ("v 0 0 0\nv 1 e 0\n", 2, "`v` needs three"),
            ("v 0 0 0 0\n", 1, "w = 0"),
            ("v 1e308 0 0 1e-10\n", 1, "not finite"),
            ("v 0 0 0\nf 1 1/2/3/4 1\n", 2, "a corner must be"),
            ("v 0 0 0\nf 1 0 1\n", 2, "vertex index 0"),
            ("v 0 0 0\nf 1 -2 1\n", 2, "before the first vertex"),
            (
                "v 0 0 0\nf 1 -9223372036854775808 1\n",
                2,
                "before the first vertex",
            ),
            ("v 0 0 0\nf 1 99999999999999999999 1\n", 2, "a corner must be"),
            ("v 0 0 0\nf 1 1\n", 2, "has 2 corners"),
            (
                "v 0 0 0\nv 1 0 0\nf 1 2 3\n",
                3,
                "refers to vertex 3, but the file has 2",
            ),
            ("usemtl\n", 1, "`usemtl` needs"),
        ] {
            let e = parse(obj, "").unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("d/m.obj: line {line}: ")) && e.contains(words),
                "{obj:?}: {e}"
            );
        }
    }

    #[test]
    fn a_material_change_splits_a_group_and_names_stay_unique() {
        let obj = format!("mtllib m.mtl\n{SQUARE}o a\nf 1 2 3\nusemtl red\nf 1 3 4\no a\nf 1 2 4\n");
        let s = parse(&obj, "newmtl red\nKd 0.5 0.1 0.1\n").unwrap();
        let names: Vec<&str> = s.iter().map(|s| s.geometry.name.as_str()).collect();
        assert_eq!(names, ["mesh0:a", "mesh0:a#1", "mesh0:a#2"]);
        assert_eq!(s[1].reflectance, Reflectance([0.5, 0.1, 0.1]));
        assert_eq!(
            s[2].reflectance,
            Reflectance([0.5, 0.1, 0.1]),
            "a material stays across `o`"
        );
    }
}
