//! Saving a room (`scene::save`): permissions, read-only files, symlinks, hard links, changes on
//! disk, comments inside an edited `lid` array, stale temporary files, save-as.

use std::fs;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use haiko::scene::save::{IfChanged, SaveError, remove_stale_temporaries, save_room, save_room_as};
use haiko::scene::{Light, RoomText, load, read_room};

const ROOM: &str = r#"version = 1
[room]
size = [4.0, 4.0, 3.0]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7
[[light]]
name = "a"
position = [2.0, 2.0, 2.5]
lid = [
    [0, 1000],   # peak
    # shoulder
    [30, 800.0],
    [60, 200], # fall-off
    [90, 0],
]  # after
[[light]]
name = "b"
position = [1.0, 1.0, 2.0]
lid_file = "iso.ies"
"#;

/// A room file in a fresh directory (with the `iso.ies` it names), read as an editor would.
struct Opened {
    dir: tempfile::TempDir,
    path: PathBuf,
    text: RoomText,
    lights: Vec<Light>,
}

fn open() -> Opened {
    let dir = tempfile::tempdir().unwrap();
    let iso = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ies/isotropic.ies");
    fs::copy(iso, dir.path().join("iso.ies")).unwrap();
    let path = dir.path().join("room.toml");
    fs::write(&path, ROOM).unwrap();
    let text = read_room(&path).unwrap();
    let lights = load(&path).unwrap().lights;
    Opened {
        dir,
        path,
        text,
        lights,
    }
}

impl Opened {
    /// Saves `now` over the file.
    fn save(&self, now: &[Light], if_changed: IfChanged) -> Result<String, SaveError> {
        save_room(&self.path, &self.text, &self.lights, now, if_changed).map(|s| s.message)
    }

    /// The lights with light 0's curve point `k` set to `cd`.
    fn with_intensity(&self, k: usize, cd: f64) -> Vec<Light> {
        let mut now = self.lights.clone();
        now[0].curve.set_intensity(k, cd).unwrap();
        now
    }
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap()
}

/// `ROOM`'s lid array replaced by `lid` (the lines between `lid = [` and `]  # after`).
fn room_with_lid(lid: &str) -> String {
    let start = ROOM.find("lid = [\n").unwrap();
    let end = ROOM.find("]  # after").unwrap();
    format!("{}lid = [\n{lid}{}", &ROOM[..start], &ROOM[end..])
}

#[test]
fn comments_inside_an_edited_lid_array_are_kept() {
    let room = open();
    room.save(&room.with_intensity(1, 850.0), IfChanged::Refuse)
        .unwrap();
    assert_eq!(
        read(&room.path),
        room_with_lid(
            "    [0, 1000],   # peak\n    # shoulder\n    [30, 850],\n    [60, 200], # fall-off\n    [90, 0],\n"
        )
    );

    // A deleted point's comments move to the point after it.
    let room = open();
    let mut now = room.lights.clone();
    now[0].curve.remove(1).unwrap();
    room.save(&now, IfChanged::Refuse).unwrap();
    assert_eq!(
        read(&room.path),
        room_with_lid("    [0, 1000],   # peak\n    # shoulder\n    [60, 200], # fall-off\n    [90, 0],\n")
    );

    // An inserted point takes the array's indentation.
    let room = open();
    let mut now = room.lights.clone();
    now[0].curve.insert(45.0, 500.0).unwrap();
    room.save(&now, IfChanged::Refuse).unwrap();
    assert_eq!(
        read(&room.path),
        room_with_lid(
            "    [0, 1000],   # peak\n    # shoulder\n    [30, 800.0],\n    [45, 500],\n    [60, 200], # fall-off\n    [90, 0],\n"
        )
    );
}

#[test]
fn permissions_are_kept_and_a_read_only_file_is_refused() {
    let room = open();
    fs::set_permissions(&room.path, fs::Permissions::from_mode(0o640)).unwrap();
    room.save(&room.with_intensity(0, 900.0), IfChanged::Refuse)
        .unwrap();
    assert_eq!(
        fs::metadata(&room.path).unwrap().permissions().mode() & 0o777,
        0o640
    );
    assert!(read(&room.path).contains("[0, 900],   # peak"));

    let room = open();
    fs::set_permissions(&room.path, fs::Permissions::from_mode(0o444)).unwrap();
    let err = room
        .save(&room.with_intensity(0, 900.0), IfChanged::Overwrite)
        .unwrap_err();
    assert!(matches!(err, SaveError::ReadOnly { .. }), "{err}");
    assert!(
        err.to_string()
            .ends_with("room.toml: cannot save: the file is read-only (save as another file)"),
        "{err}"
    );
    assert_eq!(read(&room.path), ROOM);
    assert_eq!(haiko::Error::from(err).exit_code(), 2);
}

#[test]
fn a_symlink_is_written_through_to_its_target() {
    let room = open();
    let link = room.dir.path().join("link.toml");
    std::os::unix::fs::symlink("room.toml", &link).unwrap();
    let now = room.with_intensity(0, 900.0);
    save_room(&link, &room.text, &room.lights, &now, IfChanged::Refuse).unwrap();
    assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert!(read(&room.path).contains("[0, 900],   # peak"));
}

#[test]
fn a_hard_linked_file_is_refused() {
    let room = open();
    let other = room.dir.path().join("other-name.toml");
    fs::hard_link(&room.path, &other).unwrap();
    let err = room
        .save(&room.with_intensity(0, 900.0), IfChanged::Overwrite)
        .unwrap_err();
    assert!(matches!(err, SaveError::HardLinked { links: 2, .. }), "{err}");
    assert!(err.to_string().contains("2 hard links"), "{err}");
    assert_eq!(read(&room.path), ROOM);
    assert_eq!(read(&other), ROOM);
}

#[test]
fn a_change_on_disk_is_detected_and_overwrite_writes_ours() {
    let room = open();
    let theirs = ROOM.replace("[60, 200], # fall-off", "[60, 250], # fall-off");
    fs::write(&room.path, &theirs).unwrap();
    let now = room.with_intensity(0, 900.0);
    let err = room.save(&now, IfChanged::Refuse).unwrap_err();
    assert!(
        matches!(err, SaveError::ChangedOnDisk { exists: true, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("changed on disk"), "{err}");
    assert_eq!(read(&room.path), theirs, "nothing written");
    room.save(&now, IfChanged::Overwrite).unwrap();
    let ours = read(&room.path);
    assert!(
        ours.contains("[0, 900],   # peak") && ours.contains("[60, 200], # fall-off"),
        "{ours}"
    );

    // A removed file is a change too; overwriting writes it anew.
    let room = open();
    fs::remove_file(&room.path).unwrap();
    let err = room.save(&now, IfChanged::Refuse).unwrap_err();
    assert!(
        matches!(err, SaveError::ChangedOnDisk { exists: false, .. }),
        "{err}"
    );
    room.save(&now, IfChanged::Overwrite).unwrap();
    assert!(read(&room.path).contains("[0, 900],   # peak"));
}

#[test]
fn the_next_save_compares_against_what_was_saved() {
    let room = open();
    let first = room.with_intensity(0, 900.0);
    let saved = save_room(&room.path, &room.text, &room.lights, &first, IfChanged::Refuse).unwrap();
    let mut second = first.clone();
    second[0].curve.set_intensity(0, 950.0).unwrap();
    save_room(&room.path, &saved.room, &first, &second, IfChanged::Refuse).unwrap();
    assert!(read(&room.path).contains("[0, 950],   # peak"));
}

#[test]
fn stale_temporary_files_of_the_room_are_removed() {
    let room = open();
    // What a kill during a save leaves: process ids above 2^22 are never alive.
    let stale = room.dir.path().join(".room.toml.haiko-tmp-99999999-3");
    let old_style = room.dir.path().join(".room.toml.haiko-save-99999999");
    fs::write(&stale, "partial").unwrap();
    fs::write(&old_style, "partial").unwrap();
    let mut removed = remove_stale_temporaries(&room.path).unwrap();
    removed.sort();
    assert_eq!(removed, vec![old_style.clone(), stale.clone()]);
    assert!(!stale.exists() && !old_style.exists() && room.path.exists());
}

#[test]
fn save_as_elsewhere_keeps_the_files_the_room_names() {
    let room = open();
    let elsewhere = tempfile::tempdir().unwrap();
    let copy = elsewhere.path().join("copy.toml");
    let now = room.with_intensity(0, 900.0);
    save_room_as(&copy, &room.path, &room.text, &room.lights, &now).unwrap();
    let text = read(&copy);
    let iso = fs::canonicalize(room.dir.path()).unwrap().join("iso.ies");
    assert!(
        text.contains(&format!("lid_file = \"{}\"", iso.display())),
        "{text}"
    );
    let loaded = load(&copy).unwrap();
    assert_eq!(loaded.lights[1].curve, room.lights[1].curve);
    assert_eq!(loaded.lights[0].curve.intensities_cd()[0], 900.0);
    assert_eq!(read(&room.path), ROOM, "the original is untouched");
}
