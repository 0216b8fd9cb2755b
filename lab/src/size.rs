//! `lab size`: flash, static RAM and stack of each board's firmware.
//!
//! Flash and RAM come from the ELF's section headers (parsed here, no tool needed): flash =
//! `.vector_table + .text + .rodata + .data`, RAM = `.data + .bss + .uninit`. The stack is
//! the high-water mark the firmware measures by stack painting, after a real run: the 3DTK
//! recording through `pyramid run --board qemu|netduinoplus2|microbit` (the demo's flags; the
//! micro:bit's 16-cell windows to 4 m, under the paper's rule, the only one it is built with), with the run's wall time and its maps' hash beside the
//! in-process host's. The NUCLEO-F446RE build's stack needs its board (`null`). With `--json` the one JSON object is all that goes to
//! stdout; progress goes to stderr.
use crate::demo::{record_3dtk, run_args, shared_data, FLAGS_3DTK};
use serde::Serialize;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;
use terrain_pyramid_host::emulator::{build_firmware, qemu_available, BOARD_DIR, INSTALL_HINT};
use terrain_pyramid_host::run::{self, Board};

/// Arguments of `lab size`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize, Debug)]
struct BoardSize {
    name: &'static str,
    flash_bytes: u64,
    ram_bytes: u64,
    stack_bytes: Option<u64>,
    /// The 3DTK recording through the board in QEMU (emulated boards).
    run_3dtk: Option<Run3dtk>,
}

#[derive(Serialize, Debug)]
struct Sizes {
    boards: Vec<BoardSize>,
}

/// Flash and static RAM of an ELF32 little-endian image, bytes.
///
/// # Errors
/// Not an ELF32 LE file.
pub fn elf_sizes(data: &[u8]) -> Result<(u64, u64), String> {
    let u16_at = |o: usize| data.get(o..o + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
    let u32_at = |o: usize| {
        data.get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if data.get(..6) != Some(&[0x7F, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let bad = || "truncated ELF".to_string();
    let shoff = u32_at(0x20).ok_or_else(bad)? as usize;
    let shentsize = usize::from(u16_at(0x2E).ok_or_else(bad)?);
    let shnum = usize::from(u16_at(0x30).ok_or_else(bad)?);
    let shstrndx = usize::from(u16_at(0x32).ok_or_else(bad)?);
    let section = |i: usize| -> Option<(u32, u32)> {
        let at = shoff + i * shentsize;
        Some((u32_at(at)?, u32_at(at + 0x14)?))
    };
    let strtab = shoff + shstrndx * shentsize;
    let str_off = u32_at(strtab + 0x10).ok_or_else(bad)? as usize;
    let (mut flash, mut ram) = (0_u64, 0_u64);
    for i in 0..shnum {
        let (name_off, size) = section(i).ok_or_else(bad)?;
        let start = str_off + name_off as usize;
        let name = data
            .get(start..)
            .and_then(|s| s.split(|&b| b == 0).next())
            .unwrap_or(&[]);
        let size = u64::from(size);
        match name {
            b".vector_table" | b".text" | b".rodata" => flash += size,
            b".data" => {
                flash += size;
                ram += size;
            }
            b".bss" | b".uninit" => ram += size,
            _ => {}
        }
    }
    Ok((flash, ram))
}

fn sizes_of(elf: &Path) -> Result<(u64, u64), String> {
    let data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    elf_sizes(&data)
}

/// One board's run of the 3DTK recording in QEMU: its stack high-water mark, the wall time,
/// the maps' hash, and the hash of the same recording and flags in process (`None` for the
/// micro:bit, whose 16-cell pyramid the in-process host does not build: its comparison is
/// `host/tests/run_microbit.rs`).
#[derive(Serialize, Debug, Clone)]
struct Run3dtk {
    stack_bytes: Option<u64>,
    wall_s: f64,
    layers_hash: String,
    host_layers_hash: Option<String>,
}

/// The flags of the 3DTK run on `board`: the demo's, and on the micro:bit its 16-cell windows
/// with the range they can hold.
fn flags_3dtk(board: Board) -> Vec<&'static str> {
    match board {
        Board::Microbit => vec![
            "--height-m",
            "0.4",
            "--max-range-m",
            "4",
            "--gamma",
            "3",
            "--cells",
            "16",
            // Built without the plane rule (16-byte slots): it takes the paper's.
            "--rule",
            "paper",
        ],
        _ => FLAGS_3DTK.to_vec(),
    }
}

/// `pyramid run --board B` on the 3DTK recording: the summary's JSON and the wall time.
fn run_3dtk(board: Board, rec: &Path, dir: &Path) -> Result<(serde_json::Value, f64), String> {
    let started = Instant::now();
    let args = run_args(board, rec, &dir.join(board.name()), &flags_3dtk(board))?;
    let json = run::execute(&args).map_err(|(_, message)| message)?;
    let wall = started.elapsed().as_secs_f64();
    let summary = serde_json::from_str(&json).map_err(|e| e.to_string())?;
    Ok((summary, wall))
}

/// The emulated boards' runs of the 3DTK recording (or `None` without the data).
fn runs_3dtk(boards: &[Board]) -> Result<Option<Vec<Run3dtk>>, String> {
    let scan = shared_data().join("3dtk-tilt-scan").join("scan000.3d");
    if !scan.is_file() {
        eprintln!("note: {} is absent: no stack measurement", scan.display());
        return Ok(None);
    }
    let dir = std::env::temp_dir().join(format!("lab-size-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let rec = dir.join("scan000.rec");
    let result = record_3dtk(&rec).and_then(|()| {
        let (host, _) = run_3dtk(Board::Host, &rec, &dir)?;
        let host_hash = host["layers_hash"].as_str().map(str::to_string);
        boards
            .iter()
            .map(|&board| {
                let (summary, wall_s) = run_3dtk(board, &rec, &dir)?;
                Ok(Run3dtk {
                    stack_bytes: summary["stack_bytes"].as_u64(),
                    wall_s,
                    layers_hash: summary["layers_hash"].as_str().unwrap_or("").to_string(),
                    host_layers_hash: (board != Board::Microbit)
                        .then(|| host_hash.clone())
                        .flatten(),
                })
            })
            .collect::<Result<Vec<_>, String>>()
    });
    let _ = std::fs::remove_dir_all(&dir);
    result.map(Some)
}

fn measure() -> Result<Sizes, String> {
    let emulated = [Board::Qemu, Board::Netduinoplus2, Board::Microbit];
    let mut boards = Vec::new();
    for board in emulated {
        let machine = board.machine().ok_or("an emulated board has a machine")?;
        let (flash_bytes, ram_bytes) = sizes_of(&machine.build()?)?;
        boards.push(BoardSize {
            name: board.name(),
            flash_bytes,
            ram_bytes,
            stack_bytes: None,
            run_3dtk: None,
        });
    }
    if qemu_available() {
        if let Some(runs) = runs_3dtk(&emulated)? {
            for (b, r) in boards.iter_mut().zip(runs) {
                b.stack_bytes = r.stack_bytes;
                b.run_3dtk = Some(r);
            }
        }
    } else {
        eprintln!("note: {INSTALL_HINT}");
    }
    // The NUCLEO-F446RE build: its stack is measured on the board (logged over RTT).
    let stm_dir = Path::new(BOARD_DIR).join("../stm32f4");
    let stm_elf = build_firmware(&stm_dir, "stm32f4-board")?;
    let (flash_bytes, ram_bytes) = sizes_of(&stm_elf)?;
    boards.push(BoardSize {
        name: "stm32f4 (NUCLEO)",
        flash_bytes,
        ram_bytes,
        stack_bytes: None,
        run_3dtk: None,
    });
    Ok(Sizes { boards })
}

/// Runs `lab size`.
pub fn run(args: &Args) -> ExitCode {
    match measure() {
        Ok(sizes) => {
            if args.json {
                if !terrain_pyramid_host::json_line::print(&sizes, "error: ") {
                    return ExitCode::FAILURE;
                }
            } else {
                println!(
                    "{:<17} {:>10} {:>14} {:>16} {:>10}  3DTK maps' hash (host's)",
                    "board", "flash (B)", "static RAM (B)", "stack (B)", "3DTK wall"
                );
                for b in &sizes.boards {
                    let stack = b
                        .stack_bytes
                        .map_or("on the board".into(), |s| s.to_string());
                    let (wall, hash) = b.run_3dtk.as_ref().map_or_else(
                        || ("-".to_string(), "-".to_string()),
                        |r| {
                            let host = r.host_layers_hash.as_deref().map_or_else(
                                || "run_microbit.rs".to_string(),
                                |h| {
                                    if h == r.layers_hash {
                                        "equal".to_string()
                                    } else {
                                        format!("DIFFERS: {h}")
                                    }
                                },
                            );
                            (
                                format!("{:.1} s", r.wall_s),
                                format!("{} ({host})", r.layers_hash),
                            )
                        },
                    );
                    println!(
                        "{:<17} {:>10} {:>14} {:>16} {:>10}  {}",
                        b.name, b.flash_bytes, b.ram_bytes, stack, wall, hash
                    );
                }
            }
            ExitCode::SUCCESS
        }
        Err(e) => crate::command_failed(e),
    }
}
