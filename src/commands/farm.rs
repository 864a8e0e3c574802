//! `lightlearn farm`: an Open Job Description job (specification jobtemplate-2023-09) that
//! renders a still or an animation in sample chunks and merges them, for any OpenJD farm
//! (AWS Deadline Cloud's format; `openjd run JOBDIR/template.yaml` runs it locally).
//!
//! Layout of a job's output (the OutputDir parameter):
//! - still: `chunks/chunk-K.{exr,png,json}` per chunk, merged into `render.exr` (+ .png, .json);
//! - animation: `chunks/frame-NNNN/chunk-K/frame-NNNN.*` per (frame, chunk), merged into
//!   `frame-NNNN.exr` (+ .png, .json) and, for a learning sampler with carrying,
//!   `frame-NNNN.stats` (`merge-stats --base` of the chunks' statistics and the previous
//!   frame's, counted once).
//!
//! Chunk K renders the samples [K·spp, (K+1)·spp) (`--chunk`), so no two tasks draw the same
//! random numbers. With carrying, frame F's chunks start from frame F−1's merged statistics,
//! so the steps of frame F depend on frame F−1's statistics merge and the frames run one after
//! another (each frame's chunks in parallel); without it every task is independent. The step
//! names and file names are fixed when the job is written; the paths, image size, depth,
//! sampler, seed, sample count per chunk and the executable are job parameters whose
//! defaults are what `farm` was given.
//!
//! The file is JSON, which is YAML, so any YAML reader (and `openjd check`) takes it.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::{json, Value};

use crate::render::LightSampler;
use crate::scene::animated::AnimatedScene;

/// What `farm` is asked for.
#[derive(Clone, Debug)]
pub struct FarmRequest {
    pub scene: PathBuf,
    pub job_dir: PathBuf,
    pub frames: Option<(u32, u32)>,
    pub still: bool,
    pub chunks: u32,
    pub spp: u32,
    pub fps: f64,
    pub carry: bool,
    pub forget: f32,
    pub sampler: LightSampler,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_depth: u32,
    /// The executable the tasks run (the Lightlearn parameter's default).
    pub lightlearn: PathBuf,
    /// Sampling, region and learning options, as command-line arguments, given to every
    /// render task.
    pub options: Vec<String>,
    /// `--exposure` in stops: the PNGs' of every render task and merge (0: none).
    pub exposure: f32,
}

/// `--exposure=EV` where the job asks for one (as one argument: EV may be negative).
fn exposure_args(req: &FarmRequest) -> Vec<String> {
    if req.exposure == 0.0 {
        Vec::new()
    } else {
        vec![format!("--exposure={}", req.exposure)]
    }
}

pub struct FarmOutcome {
    pub template: PathBuf,
    pub steps: usize,
    pub tasks: usize,
}

/// The first line of every template farm writes (how a job folder is told from a user's).
const TEMPLATE_HEADER: &str =
    "# Open Job Description job template written by `lightlearn farm` (JSON is YAML).";
/// Most chunks an image may have.
const MAX_CHUNKS: u32 = 1000;
/// Most steps a job may have (two or three per frame); OpenJD's own limit is far above.
const MAX_FRAMES: u32 = 2000;
/// The most (frame, chunk) render tasks a job takes: 2000 frames of 50 chunks.
const MAX_RENDER_TASKS: u64 = 100_000;

/// A job bundle's files: (path relative to the job folder, bytes).
type Bundle = Vec<(PathBuf, Vec<u8>)>;

/// The files of the scene's bundle (the .gltf or .glb with the buffers and images it names
/// by relative URI), read before anything is written, and the scene's path relative to the
/// job folder: JOBDIR/scene/NAME. OpenJD takes a PATH parameter's default relative to the
/// template and never outside it, and a farm sends the bundle's files to its workers. A file
/// that cannot be read fails the job before any file of it is written (a failing farm run
/// had replaced an existing job's scene and left the new one half-copied).
fn bundle_files(scene: &Path) -> Result<(String, Bundle)> {
    let name = scene
        .file_name()
        .ok_or_else(|| anyhow::anyhow!("'{}' names no file", scene.display()))?;
    let mut files = vec![(PathBuf::from(name), PathBuf::from(name))];
    // A .glb names external buffers and images by URI as a .gltf does: its bundle held the
    // .glb alone, and the job rendered without its textures, exit 0 (an audit, 2026-12-07).
    let bytes = crate::io::read_all(scene)
        .with_context(|| format!("cannot read '{}' for the job bundle", scene.display()))?;
    // The URIs alone kept: the parsed file holds a copy of a .glb's binary chunk (a review).
    let uris: Vec<String> = {
        let (gltf, _) = crate::scene::gltf_parse::parse(&bytes, "").map_err(|e| {
            anyhow::anyhow!(
                "'{}' is not a valid glTF 2.0 file (.gltf or .glb): {e}",
                scene.display()
            )
        })?;
        let root = gltf.as_json();
        (root.buffers.iter().filter_map(|b| b.uri.clone()))
            .chain(root.images.iter().filter_map(|i| i.uri.clone()))
            .collect()
    };
    for uri in uris.iter().filter(|u| !u.starts_with("data:")) {
        // The file the loader reads (it decodes %XX), kept under the URI's own decoded
        // name, where the loader looks for it in the bundle. Without `.` parts, so
        // `./t.png` and `t.png` are one file of the bundle.
        let rel: PathBuf = PathBuf::from(crate::scene::percent_decode(uri))
            .components()
            .filter(|c| *c != std::path::Component::CurDir)
            .collect();
        if rel.is_absolute()
            || rel
                .components()
                .any(|c| c == std::path::Component::ParentDir)
        {
            bail!("'{}' refers to '{uri}' outside its folder; a job bundle holds only files beside the scene (embed the data or move the file next to it)", scene.display());
        }
        if !files.iter().any(|(f, _)| *f == rel) {
            files.push((rel.clone(), rel));
        }
    }
    let from = scene.parent().unwrap_or(Path::new("."));
    let scene_dir = Path::new("scene");
    let mut read = Vec::new();
    // The scene (the first file) as read above, once.
    let mut scene_bytes = Some(bytes);
    for (source, target) in files {
        let bytes = match scene_bytes.take() {
            Some(b) => b,
            None => crate::io::read_all(&from.join(&source)).with_context(|| {
                format!(
                    "cannot read '{}' for the job bundle",
                    from.join(&source).display()
                )
            })?,
        };
        read.push((scene_dir.join(target), bytes));
    }
    // The bundled scene under a name a template can hold: its SceneFile default may not
    // hold a control character (the scene's own name is not referred to by its buffers).
    let bundled = plain(&name.to_string_lossy());
    if read[1..]
        .iter()
        .any(|(t, _)| *t == scene_dir.join(&bundled))
    {
        bail!(
            "'{}' would be bundled as '{bundled}', the name of a file it refers to; rename the scene",
            scene.display()
        );
    }
    if let Some(first) = read.first_mut() {
        first.0 = scene_dir.join(&bundled);
    }
    Ok((path(&scene_dir.join(bundled))?, read))
}

/// `s` with its control characters and braces replaced by `_`: a job's name is an OpenJD
/// format string (`{{Param.X}}` in a scene's file name made the template fail `openjd
/// check`, exit 0 from farm; an audit, 2026-12-06), and neither it nor a path default may
/// hold a newline.
fn plain(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_control() || c == '{' || c == '}' {
                '_'
            } else {
                c
            }
        })
        .collect()
}

fn path(p: &Path) -> Result<String> {
    p.to_str().map(str::to_string).ok_or_else(|| {
        anyhow::anyhow!(
            "'{}' is not valid UTF-8; a job template needs text paths",
            p.display()
        )
    })
}

fn param(name: &str) -> String {
    format!("{{{{Param.{name}}}}}")
}

fn out(rel: &str) -> String {
    format!("{}/{rel}", param("OutputDir"))
}

fn args(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// The options every render task shares, as job parameters where they are ones.
fn common_args(req: &FarmRequest) -> Vec<String> {
    // Numbers as one `--flag=value` argument: a value a scheduler let through below its
    // minValue (openjd-cli does not check them locally) is then clap's one-line "invalid
    // value '-1' for '--seed'", not its advice to write `-- -1` (an audit, 2026-12-07).
    let joined = |flag: &str, name: &str| format!("{flag}={}", param(name));
    let mut a = vec![
        joined("--spp", "ChunkSpp"),
        joined("--width", "Width"),
        joined("--height", "Height"),
        joined("--max-depth", "MaxDepth"),
        "--sampler".to_string(),
        param("Sampler"),
        joined("--seed", "Seed"),
        "--chunk".to_string(),
        "{{Task.Param.Chunk}}".to_string(),
        "-q".to_string(),
    ];
    a.extend(req.options.iter().cloned());
    a.extend(exposure_args(req));
    a
}

fn chunk_space(chunks: u32) -> Value {
    json!({"taskParameterDefinitions": [
        {"name": "Chunk", "type": "INT", "range": format!("0-{}", chunks - 1)}
    ]})
}

fn run_action(arguments: Vec<String>) -> Value {
    json!({"actions": {"onRun": {"command": param("Lightlearn"), "args": arguments}}})
}

/// Writes JOBDIR/template.yaml.
/// `warn` hears what the scene's loader and the frame range call for a word on, as it comes
/// (they were dropped, and a job of a file with ignored channels or frames past its end was
/// written without one; an audit, 2026-12-07).
pub fn write(req: &FarmRequest, warn: &mut dyn FnMut(String)) -> Result<FarmOutcome> {
    // A refused job leaves no empty job folder behind.
    crate::io::removing_created_folders_on_error(Some(&req.job_dir), || write_checked(req, warn))
}

fn write_checked(req: &FarmRequest, warn: &mut dyn FnMut(String)) -> Result<FarmOutcome> {
    // A Merge step lists every chunk's file on one command line: 10000 chunks in a job
    // folder of ~170 bytes passed the 2 MiB the system takes, after every render task had
    // run (an audit, 2026-12-07). 1000 of 2^20 samples each are 2^30, all a pixel's random
    // streams hold.
    if !(2..=MAX_CHUNKS).contains(&req.chunks) {
        bail!("--chunks must be 2..={MAX_CHUNKS} (a merge names every chunk's file on one command line; for one chunk, run `lightlearn render` or `animate` directly)");
    }
    if req.spp == 0 {
        bail!("--spp (samples per chunk) must be at least 1");
    }
    // Each task renders --spp: past a film's 2^20 every task failed (a review, 2026-12-07).
    let most = crate::render::MAX_FILM_SPP;
    if req.spp > most {
        bail!("--spp {} is more than the {most} samples per pixel a chunk's film adds without loss; use more --chunks of fewer samples", req.spp);
    }
    // In farm's own flags: the task's "--chunk K" is not one of them (an audit, 2026-12-06).
    if super::render::chunk_offset(Some(req.chunks - 1), Some(req.spp)).is_err() {
        bail!(
            "--chunks {} × --spp {}: the last chunk would end at pass {}, past the first 2^30 passes of the random streams, where a chunk must end; use fewer chunks or fewer samples a chunk",
            req.chunks,
            req.spp,
            req.chunks as u64 * req.spp as u64
        );
    }
    super::check_depth(req.max_depth)?;
    super::check_size(req.width, req.height)?;
    super::animate::check_timing(req.fps, req.forget)?;
    let scene = std::fs::canonicalize(&req.scene)
        .with_context(|| format!("cannot find the scene '{}'", req.scene.display()))?;
    let anim = AnimatedScene::open(Some(&scene), warn)?;
    let frames = match (req.frames, req.still) {
        (_, true) => None,
        (Some((a, b)), _) if b < a => {
            bail!("--frames {a}..{b}: the last frame comes before the first")
        }
        (Some(r), _) => Some(r),
        (None, _) if anim.is_animated() => Some((0, anim.frame_count(req.fps)? - 1)),
        (None, _) => None,
    };
    if let Some((a, b)) = frames {
        if b - a >= MAX_FRAMES {
            bail!("--frames {a}..{b}: at most {MAX_FRAMES} frames per job; write several jobs");
        }
        if anim.is_animated() {
            let end = anim.frame_count(req.fps).unwrap_or(u32::MAX) - 1;
            if b > end {
                warn(format!(
                    "'{}' ends at frame {end} at {} fps; frames {}..{b} hold its last pose",
                    anim.doc.name(),
                    req.fps,
                    a.max(end + 1)
                ));
            }
        }
        // Each flag within its limit, 2000 frames × 10000 chunks made 20 M tasks: the
        // template (it lists each chunk's files for the merges) ran out of memory and
        // aborted (an audit, 2026-12-06).
        let tasks = (b - a + 1) as u64 * req.chunks as u64;
        if tasks > MAX_RENDER_TASKS {
            bail!(
                "--frames {a}..{b} × --chunks {} is {tasks} render tasks, more than the {MAX_RENDER_TASKS} one job holds (its template lists every chunk's files); use fewer chunks, or split the frames over several jobs",
                req.chunks
            );
        }
        // Carried statistics count every frame's chunks: the last frame's sample ranges
        // must stay within the random streams a continuation may use.
        let total = (b - a + 1) as u64 * req.chunks as u64 * req.spp as u64;
        if req.carry && req.sampler.learned() && total > (crate::render::MAX_PASSES / 2) as u64 {
            bail!("{} frames × {} chunks × {} spp carried from frame to frame is {total} passes, more than the 2^30 the random streams hold; fewer frames per job, chunks or spp", b - a + 1, req.chunks, req.spp);
        }
    }
    // openjd cannot run a job from a path that is not text (it failed with a
    // UnicodeEncodeError; an audit, 2026-12-07).
    path(&req.job_dir)?;
    crate::io::create_output_folder(&req.job_dir, "job folder")?;
    let template_path = req.job_dir.join("template.yaml");
    crate::io::check_writable(&template_path)?;
    // A job folder holding a template lightlearn did not write is a user's folder, whose
    // template and scene/ files were replaced without a word (an audit, 2026-12-07).
    let ours = crate::io::read_regular(&template_path, TEMPLATE_HEADER.len() as u64)
        .is_ok_and(|b| b == TEMPLATE_HEADER.as_bytes());
    if std::fs::symlink_metadata(&template_path).is_ok() && !ours {
        bail!(
            "'{}' exists and was not written by `lightlearn farm`; give another --out (a new folder, or an earlier farm job's)",
            template_path.display()
        );
    }
    if std::fs::canonicalize(&req.job_dir)?
        .starts_with(scene.parent().unwrap_or(Path::new("/")).join("scene"))
    {
        bail!(
            "--out '{}' lies inside the scene's own folder's scene/; choose another job folder",
            req.job_dir.display()
        );
    }
    let (bundled, bundle) = bundle_files(&scene)?;
    // Frames that carry statistics have steps that merge and pass on each frame's files: a
    // sampler that learns nothing writes none, and the job failed at its first merge with
    // "cannot read the statistics file" (an audit, 2026-12-06). Offer only those that learn.
    let carries = frames.is_some() && req.carry && req.sampler.learned();
    // A frame's chunks refine their cuts apart, and the job's merge of their statistics
    // refused them at its first frame (an audit, 2026-12-07: exit 1 after frame 0).
    let refines = (req.options.iter())
        .position(|o| o == "--refine-cuts")
        .and_then(|i| req.options.get(i + 1))
        .is_some_and(|n| n != "0");
    if carries && refines {
        bail!("--refine-cuts with statistics carried from frame to frame: each chunk of a frame refines its cuts from its own samples, so their statistics cannot be merged for the next frame; leave out --refine-cuts, or give --carry off");
    }
    let samplers: Vec<&str> = (LightSampler::ALL.iter())
        .filter(|s| s.learned() || !carries)
        .map(|s| s.name())
        .collect();
    let parameters = json!([
        {"name": "SceneFile", "type": "PATH", "objectType": "FILE", "dataFlow": "IN",
         "default": bundled,
         "description": "The glTF scene to render (the default, the bundled copy, is in the template's folder; a relative path given when the job is run or submitted is taken from where that command runs)."},
        {"name": "OutputDir", "type": "PATH", "objectType": "DIRECTORY", "dataFlow": "OUT",
         "default": "output",
         "description": "Where the chunks and the merged images go (the default is inside the job's folder; a relative path given when the job is run or submitted is taken from where that command runs)."},
        {"name": "Lightlearn", "type": "STRING", "minLength": 1,
         "default": path(&req.lightlearn)?,
         "description": "The lightlearn executable on the workers (a path, or `lightlearn` when it is on their PATH)."},
        {"name": "ChunkSpp", "type": "INT", "minValue": 1,
         "maxValue": crate::render::MAX_FILM_SPP, "default": req.spp,
         "description": "Samples per pixel of each chunk; an image gets chunks × this."},
        {"name": "Width", "type": "INT", "minValue": 1, "maxValue": super::MAX_SIZE, "default": req.width},
        {"name": "Height", "type": "INT", "minValue": 1, "maxValue": super::MAX_SIZE, "default": req.height},
        {"name": "MaxDepth", "type": "INT", "minValue": 1, "maxValue": super::MAX_DEPTH,
         "default": req.max_depth, "description": "Surface vertices of a path (1 = direct light)."},
        {"name": "Sampler", "type": "STRING", "allowedValues": samplers,
         "default": req.sampler.name(),
         "description": if carries {
             "The light sampler; the frames carry its learned statistics, so one that learns."
         } else {
             "The light sampler."
         }},
        {"name": "Seed", "type": "INT", "minValue": 0, "maxValue": u32::MAX, "default": req.seed,
         "description": "Random seed, 0 to 4294967295 (chunks and frames mix in their index)."},
    ]);
    let chunk_list = |f: &dyn Fn(u32) -> String| (0..req.chunks).map(f).collect::<Vec<_>>();
    let mut steps = Vec::new();
    let mut tasks = 0usize;
    match frames {
        None => {
            let mut a = args(&["render", &param("SceneFile"), "--mkdir", "--out"]);
            a.push(out("chunks/chunk-{{Task.Param.Chunk}}.exr"));
            a.extend(common_args(req));
            steps.push(json!({
                "name": "Render",
                "parameterSpace": chunk_space(req.chunks),
                "script": run_action(a),
            }));
            let mut m = vec!["merge".to_string()];
            m.extend(chunk_list(&|k| out(&format!("chunks/chunk-{k}.exr"))));
            m.extend(["--out".to_string(), out("render.exr")]);
            m.extend(exposure_args(req));
            steps.push(json!({
                "name": "Merge",
                "dependencies": [{"dependsOn": "Render"}],
                "script": run_action(m),
            }));
            tasks += req.chunks as usize + 1;
        }
        Some((first, last)) => {
            let stats = carries;
            for f in first..=last {
                let dir = format!("chunks/frame-{f:04}");
                let mut a = args(&[
                    "animate",
                    &param("SceneFile"),
                    "--frame",
                    &f.to_string(),
                    "--fps",
                    &req.fps.to_string(),
                    "--carry",
                    if req.carry { "on" } else { "off" },
                    "--forget",
                    &req.forget.to_string(),
                    "--no-video",
                    // The chunk's folder is the job's own: a retry after a kill between
                    // the renames of a frame's image and report (an image with no report)
                    // would be refused as a user's file for good (a review, 2026-12-07).
                    "--force",
                    "--out",
                ]);
                a.push(out(&format!("{dir}/chunk-{{{{Task.Param.Chunk}}}}")));
                a.extend(common_args(req));
                let mut render = json!({
                    "name": format!("Render frame {f}"),
                    "parameterSpace": chunk_space(req.chunks),
                });
                if stats && f > first {
                    a.extend([
                        "--load-stats".to_string(),
                        out(&format!("frame-{:04}.stats", f - 1)),
                    ]);
                    render["dependencies"] =
                        json!([{"dependsOn": format!("Merge statistics {}", f - 1)}]);
                }
                render["script"] = run_action(a);
                steps.push(render);
                let part = |k: u32, ext: &str| out(&format!("{dir}/chunk-{k}/frame-{f:04}.{ext}"));
                let mut m = vec!["merge".to_string()];
                m.extend(chunk_list(&|k| part(k, "exr")));
                m.extend(["--out".to_string(), out(&format!("frame-{f:04}.exr"))]);
                m.extend(exposure_args(req));
                steps.push(json!({
                    "name": format!("Merge frame {f}"),
                    "dependencies": [{"dependsOn": format!("Render frame {f}")}],
                    "script": run_action(m),
                }));
                tasks += req.chunks as usize + 1;
                if stats {
                    let mut m = vec!["merge-stats".to_string()];
                    m.extend(chunk_list(&|k| part(k, "stats")));
                    m.extend(["--out".to_string(), out(&format!("frame-{f:04}.stats"))]);
                    if f > first {
                        m.extend([
                            "--base".to_string(),
                            out(&format!("frame-{:04}.stats", f - 1)),
                        ]);
                    }
                    steps.push(json!({
                        "name": format!("Merge statistics {f}"),
                        "dependencies": [{"dependsOn": format!("Render frame {f}")}],
                        "script": run_action(m),
                    }));
                    tasks += 1;
                }
            }
        }
    }
    // Job names hold at most 128 characters.
    let name: String = plain(
        &scene
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default(),
    )
    .chars()
    .take(64)
    .collect();
    let what = match frames {
        Some((a, b)) => format!("frames {a}..{b}"),
        None => "still".to_string(),
    };
    let template = json!({
        "specificationVersion": "jobtemplate-2023-09",
        "name": format!("lightlearn {name} {what}, {} chunks", req.chunks),
        "description": format!(
            "Written by lightlearn {} farm. Each chunk renders ChunkSpp samples of its own \
             sample range; Merge steps combine them.",
            env!("CARGO_PKG_VERSION")
        ),
        "parameterDefinitions": parameters,
        "steps": steps,
    });
    // The path in the comment as text of one line: a line break in the job folder's name
    // ended the comment and the template was no YAML (an audit, 2026-12-07).
    let text = format!(
        "{TEMPLATE_HEADER}\n# Run it here: openjd run {}\n{}\n",
        plain(&template_path.display().to_string()),
        serde_json::to_string_pretty(&template)?
    );
    // Written over an earlier job: what it left that this one does not replace is said
    // (its bundled scene and its outputs stayed without a word; an audit, 2026-12-07).
    // Neither is removed: the outputs are rendered work, scene/ may hold a user's files.
    if ours {
        let mine: Vec<PathBuf> = bundle
            .iter()
            .map(|(rel, _)| req.job_dir.join(rel))
            .collect();
        let stale: Vec<String> = std::fs::read_dir(req.job_dir.join("scene"))
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| e.path().is_file() && !mine.contains(&e.path()))
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        if !stale.is_empty() {
            warn(format!(
                "'{}' also holds {} of an earlier job ({}), left as they are",
                req.job_dir.join("scene").display(),
                if stale.len() == 1 { "a file" } else { "files" },
                stale.join(", ")
            ));
        }
        let output = req.job_dir.join("output");
        if std::fs::read_dir(&output).is_ok_and(|mut d| d.next().is_some()) {
            warn(format!(
                "'{}' holds an earlier job's outputs: this job writes over those of its own frames and leaves the rest (move them away to keep the jobs apart)",
                output.display()
            ));
        }
    }
    // The bundle and the template together: all or none (io::commit_all). The folders
    // made for the bundle go again if that fails (a full disk left an empty scene/ in the
    // job folder; an audit, 2026-12-06).
    let mut made: Vec<PathBuf> = Vec::new();
    let result = (|| -> Result<()> {
        let mut set = crate::io::FileSet::default();
        for (rel, bytes) in &bundle {
            let target = req.job_dir.join(rel);
            // In a folder that is no farm job's, a file of another content there is a
            // user's (the scene's own folder as --out: its scene/t.png was replaced).
            if !ours && crate::io::read_regular(&target, 1 << 34).is_ok_and(|b| b != *bytes) {
                bail!(
                    "'{}' exists with other content than the job's copy of '{}'; give another --out (a new folder, or an earlier farm job's)",
                    target.display(),
                    rel.strip_prefix("scene").unwrap_or(rel).display()
                );
            }
            if let Some(parent) = target.parent() {
                made.extend(
                    parent
                        .ancestors()
                        .take_while(|p| !p.as_os_str().is_empty() && !p.exists())
                        .map(Path::to_path_buf),
                );
                std::fs::create_dir_all(parent)
                    .with_context(|| format!("cannot create the folder '{}'", parent.display()))?;
            }
            set.add(&target, bytes)?;
        }
        set.add(&template_path, text.as_bytes())?;
        set.commit()
    })();
    if result.is_err() {
        made.sort_by_key(|d| std::cmp::Reverse(d.components().count()));
        for d in &made {
            let _ = std::fs::remove_dir(d); // only if still empty
        }
    }
    result?;
    Ok(FarmOutcome {
        template: template_path,
        steps: steps.len(),
        tasks,
    })
}
