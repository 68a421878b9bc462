//! Scripted input for `translucent view --script FILE`: the same [`Action`]s the mouse and the
//! keyboard produce, at given frames, so a run under Xvfb (CI) replays a session exactly.
//!
//! The format: one command per line; `#` starts a comment; frames count from 0.
//!
//! ```text
//! # orbit 30 degrees left and 10 up in frame 0, then zoom in frame 2
//! orbit -30 10
//! wait 2
//! zoom 0.8
//! @10 material marble          # `@N` puts this line (and the ones after it) at frame N
//! repeat 20 light 3 0          # in each of frames 10..29: turn the key light 3 degrees
//! key p                        # what the `p` key does (next precision)
//! screenshot shot.png          # writes shot.png and shot.exr after frame 30
//! ```
//!
//! Commands: `orbit YAW PITCH` and `light YAW PITCH` (degrees), `zoom FACTOR` (distance x
//! FACTOR), `camera X,Y,Z:TX,TY,TZ:FOVY_DEG`, `reset-camera`, `material NAME`, `method NAME`,
//! `precision mixed|fp32|fp16`, `single-scattering on|off|toggle`, `skip on|off|toggle`,
//! `overlay on|off|toggle`, `help on|off|toggle`, `resize WIDTH HEIGHT`, `screenshot FILE`,
//! `key NAME` (a key of [`super::controls::BINDINGS`]: `m`, `M`, `f12`, ...), `reload-shaders`
//! (what `F5` does: shader hot reload), `quit`.
//! Timing: a line runs at the current frame (0 at the start); `@N COMMAND` moves the current
//! frame to N; `wait N` moves it N frames on; `repeat N COMMAND` runs the command in each of
//! the N frames from the current one and moves the current frame past them.

use std::collections::BTreeMap;
use std::path::Path;

use super::controls::{key_action, Action};
use crate::scene_args::parse_camera;

/// A script line that cannot be understood.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    #[error("{file}: {source}")]
    Read {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}:{line}: {problem}")]
    Line {
        file: String,
        line: usize,
        problem: String,
    },
}

/// The actions of a script, by frame (within a frame, in file order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    frames: BTreeMap<u64, Vec<Action>>,
}

/// More frames than any session needs; a larger number is a typo.
const MAX_FRAME: u64 = 10_000_000;

impl Script {
    pub fn read(path: &Path) -> Result<Script, ScriptError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ScriptError::Read {
            file: file.clone(),
            source,
        })?;
        Script::parse(&file, &text)
    }

    /// Parses `text`; errors name `file` and the line.
    pub fn parse(file: &str, text: &str) -> Result<Script, ScriptError> {
        let mut script = Script::default();
        let mut frame = 0u64;
        for (index, raw) in text.lines().enumerate() {
            let fail = |problem: String| ScriptError::Line {
                file: file.into(),
                line: index + 1,
                problem,
            };
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let mut words: Vec<&str> = line.split_whitespace().collect();
            if let Some(at) = words[0].strip_prefix('@') {
                frame = count(at, "@FRAME").map_err(fail)?;
                words.remove(0);
                if words.is_empty() {
                    continue;
                }
            }
            match words[0] {
                "wait" => {
                    let [_, n] = words[..] else {
                        return Err(fail("wait takes one number of frames".into()));
                    };
                    frame = frame
                        .checked_add(count(n, "wait").map_err(fail)?)
                        .filter(|&f| f <= MAX_FRAME)
                        .ok_or_else(|| fail(format!("frame beyond {MAX_FRAME}")))?;
                }
                "repeat" => {
                    let (Some(n), true) = (words.get(1), words.len() > 2) else {
                        return Err(fail("repeat takes a count and a command".into()));
                    };
                    let n = count(n, "repeat").map_err(fail)?;
                    let action = command(&words[2..]).map_err(fail)?;
                    if frame.saturating_add(n) > MAX_FRAME {
                        return Err(fail(format!("frame beyond {MAX_FRAME}")));
                    }
                    for f in frame..frame + n {
                        script.frames.entry(f).or_default().push(action.clone());
                    }
                    frame += n;
                }
                _ => {
                    let action = command(&words).map_err(fail)?;
                    script.frames.entry(frame).or_default().push(action);
                }
            }
        }
        Ok(script)
    }

    /// The actions of frame `frame`, in file order.
    pub fn actions_at(&self, frame: u64) -> &[Action] {
        self.frames.get(&frame).map_or(&[], Vec::as_slice)
    }

    /// The last frame with an action (`None` for an empty script).
    pub fn last_frame(&self) -> Option<u64> {
        self.frames.keys().next_back().copied()
    }
}

fn count(text: &str, what: &str) -> Result<u64, String> {
    text.parse::<u64>()
        .ok()
        .filter(|&n| n <= MAX_FRAME)
        .ok_or_else(|| format!("{what} {text:?}: expected a frame count from 0 to {MAX_FRAME}"))
}

fn number(text: &str, what: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("{what} {text:?}: expected a finite number"))
}

fn switch(words: &[&str]) -> Result<Option<bool>, String> {
    match words {
        [_, "on"] => Ok(Some(true)),
        [_, "off"] => Ok(Some(false)),
        [_, "toggle"] => Ok(None),
        _ => Err(format!("{} takes on, off or toggle", words[0])),
    }
}

/// One command (without its timing prefix).
fn command(words: &[&str]) -> Result<Action, String> {
    let two = |what: &str| -> Result<(f64, f64), String> {
        match words {
            [_, a, b] => Ok((number(a, what)?, number(b, what)?)),
            _ => Err(format!("{what} takes two numbers: YAW_DEG PITCH_DEG")),
        }
    };
    let one_word = || -> Result<&str, String> {
        match words {
            [_, w] => Ok(w),
            _ => Err(format!("{} takes one word", words[0])),
        }
    };
    Ok(match words[0] {
        "orbit" => {
            let (yaw_deg, pitch_deg) = two("orbit")?;
            Action::Orbit { yaw_deg, pitch_deg }
        }
        "light" => {
            let (yaw_deg, pitch_deg) = two("light")?;
            Action::Light { yaw_deg, pitch_deg }
        }
        "zoom" => {
            let f = number(one_word()?, "zoom")?;
            if f <= 0.0 {
                return Err(format!("zoom {f}: the factor must be positive"));
            }
            Action::Zoom(f)
        }
        "camera" => Action::Camera(parse_camera(one_word()?).map_err(|e| format!("{e:#}"))?),
        "reset-camera" => Action::ResetCamera,
        "material" => Action::Material(one_word()?.into()),
        "method" => Action::Method(one_word()?.into()),
        "precision" => {
            let p = one_word()?;
            Action::Precision(p.parse().map_err(|e| format!("precision: {e}"))?)
        }
        "single-scattering" => Action::SingleScattering(switch(words)?),
        "skip" => Action::Skip(switch(words)?),
        "overlay" => Action::Overlay(switch(words)?),
        "help" => Action::Help(switch(words)?),
        "resize" => match words {
            [_, w, h] => {
                let size = |t: &str| {
                    t.parse::<u32>()
                        .ok()
                        .filter(|v| (1..=16384).contains(v))
                        .ok_or_else(|| format!("resize {t:?}: expected 1..=16384 pixels"))
                };
                Action::Resize {
                    width: size(w)?,
                    height: size(h)?,
                }
            }
            _ => return Err("resize takes WIDTH HEIGHT".into()),
        },
        "screenshot" => Action::Screenshot(Some(one_word()?.into())),
        "key" => {
            let key = one_word()?;
            key_action(key).ok_or_else(|| format!("key {key:?} does nothing"))?
        }
        "reload-shaders" => Action::ReloadShaders,
        "quit" => Action::Quit,
        other => return Err(format!("unknown command {other:?}")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use translucent::solver::gpu::Precision;

    #[test]
    fn timing_prefixes_place_actions_at_their_frames() {
        let script = Script::parse(
            "t.script",
            "# comment\norbit -30 10\nwait 2\nzoom 0.8   # closer\n@10 material marble\nrepeat 3 light 3 0\nkey p\n@5\nskip off\n",
        )
        .expect("parses");
        assert_eq!(
            script.actions_at(0),
            &[Action::Orbit {
                yaw_deg: -30.0,
                pitch_deg: 10.0
            }]
        );
        assert_eq!(script.actions_at(2), &[Action::Zoom(0.8)]);
        assert_eq!(
            script.actions_at(10).len(),
            2,
            "material and the first light"
        );
        assert_eq!(
            script.actions_at(12),
            &[Action::Light {
                yaw_deg: 3.0,
                pitch_deg: 0.0
            }]
        );
        assert_eq!(script.actions_at(13), &[Action::CyclePrecision]);
        assert_eq!(script.actions_at(5), &[Action::Skip(Some(false))]);
        assert_eq!(script.actions_at(1), &[]);
        assert_eq!(script.last_frame(), Some(13));
        let p = Script::parse("t", "precision fp16\ncamera 0,0,100:0,0,0:30").expect("parses");
        assert_eq!(p.actions_at(0)[0], Action::Precision(Precision::Fp16));
        assert!(matches!(p.actions_at(0)[1], Action::Camera(_)));
    }

    #[test]
    fn bad_lines_name_the_file_and_line() {
        for (text, line, needle) in [
            ("orbit 1", 1, "two numbers"),
            ("\n\nzoom -1", 3, "positive"),
            ("fly 3", 1, "unknown command"),
            ("wait x", 1, "frame count"),
            ("@-1 orbit 1 1", 1, "frame count"),
            ("key z", 1, "does nothing"),
            ("skip maybe", 1, "on, off or toggle"),
            ("resize 0 10", 1, "1..=16384"),
            ("camera 0,0,0:0,0,0:30", 1, "--camera"),
            ("orbit nan 1", 1, "finite"),
            ("repeat 3", 1, "count and a command"),
            ("precision fp64", 1, "precision"),
        ] {
            let e = Script::parse("s.script", text).expect_err(text).to_string();
            assert!(
                e.starts_with(&format!("s.script:{line}: ")) && e.contains(needle),
                "{text:?}: {e}"
            );
        }
    }
}
