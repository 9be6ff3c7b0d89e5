//! The Slurm example of docs/farm.md, run for real: a private single-node
//! Slurm (munged, slurmctld, slurmd from Debian's packages) started by the
//! test, the documented job-array script submitted to it, and the frames
//! checked. One chunk is made to fail and must show as FAILED.
//!
//! Skipped, with a message, where the Slurm daemons are not installed
//! (CI installs them; see .ci/run).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const TOOLS: &[&str] = &[
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "scontrol",
    "sinfo",
];

fn find(tool: &str) -> Option<PathBuf> {
    ["/usr/sbin", "/usr/bin", "/sbin", "/bin"]
        .iter()
        .map(|d| Path::new(d).join(tool))
        .find(|p| p.is_file())
}

/// The daemons of the private cluster; stopped when the test ends.
struct Cluster {
    dir: tempfile::TempDir,
    conf: PathBuf,
    daemons: Vec<Child>,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for d in &mut self.daemons {
            let _ = d.kill();
            let _ = d.wait();
        }
    }
}

impl Cluster {
    fn start() -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        for sub in ["state", "spool", "log"] {
            std::fs::create_dir_all(root.join(sub)).unwrap();
        }
        let key = root.join("munge.key");
        let bytes: Vec<u8> = (0..1024u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        std::fs::write(&key, bytes).unwrap();
        set_mode(&key, 0o600);
        let socket = root.join("munge.sock");
        let host = String::from_utf8(Command::new("hostname").output().unwrap().stdout)
            .unwrap()
            .trim()
            .to_string();
        // Ports from the process id, so concurrent runs do not collide.
        let port = 20000 + (std::process::id() % 20000) as u16;
        let conf = root.join("slurm.conf");
        std::fs::write(
            &conf,
            format!(
                "ClusterName=soupraytest\nSlurmctldHost={host}\nSlurmUser=root\nSlurmdUser=root\n\
                 AuthType=auth/munge\nAuthInfo=socket={sock}\n\
                 StateSaveLocation={r}/state\nSlurmdSpoolDir={r}/spool\n\
                 SlurmctldPidFile={r}/slurmctld.pid\nSlurmdPidFile={r}/slurmd.pid\n\
                 SlurmctldLogFile={r}/log/slurmctld.log\nSlurmdLogFile={r}/log/slurmd.log\n\
                 SlurmctldPort={p1}\nSlurmdPort={p2}\n\
                 ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nReturnToService=2\n\
                 SchedulerType=sched/builtin\nSelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n\
                 MpiDefault=none\nJobAcctGatherType=jobacct_gather/none\n\
                 AccountingStorageType=accounting_storage/none\nMinJobAge=3600\n\
                 NodeName={host} CPUs=2 RealMemory=1000 State=UNKNOWN\n\
                 PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
                sock = socket.display(),
                r = root.display(),
                p1 = port,
                p2 = port + 1,
            ),
        )
        .unwrap();
        let mut cluster = Cluster {
            conf: conf.clone(),
            daemons: Vec::new(),
            dir,
        };
        let root = cluster.dir.path().to_path_buf();
        cluster.daemons.push(
            Command::new(find("munged").unwrap())
                .arg("--foreground")
                .arg("--force")
                .arg(format!("--socket={}", socket.display()))
                .arg(format!("--key-file={}", key.display()))
                .arg(format!("--pid-file={}", root.join("munged.pid").display()))
                .arg(format!(
                    "--log-file={}",
                    root.join("log/munged.log").display()
                ))
                .arg(format!("--seed-file={}", root.join("munge.seed").display()))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("start munged"),
        );
        wait_for(|| socket.exists(), "munged's socket");
        for daemon in ["slurmctld", "slurmd"] {
            cluster.daemons.push(
                Command::new(find(daemon).unwrap())
                    .args(["-D", "-f"])
                    .arg(&conf)
                    .env("SLURM_CONF", &conf)
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .unwrap_or_else(|e| panic!("start {daemon}: {e}")),
            );
        }
        wait_for(
            || {
                let out = cluster.client("sinfo").args(["-h", "-o", "%T"]).output();
                out.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
            },
            "the node to come up idle",
        );
        cluster
    }

    fn client(&self, tool: &str) -> Command {
        let mut c = Command::new(find(tool).unwrap());
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// `JobState` and `ExitCode` of each task of an array job, by task id.
    fn tasks(&self, job: &str) -> Vec<(u32, String, String)> {
        let out = self
            .client("scontrol")
            .args(["show", "job", job])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        let mut tasks = Vec::new();
        for record in text.split("\n\n").filter(|r| r.contains("ArrayTaskId=")) {
            let field = |name: &str| {
                record
                    .split_whitespace()
                    .find_map(|w| w.strip_prefix(&format!("{name}=")))
                    .unwrap_or("")
                    .to_string()
            };
            if let Ok(id) = field("ArrayTaskId").parse() {
                tasks.push((id, field("JobState"), field("ExitCode")));
            }
        }
        tasks.sort();
        tasks
    }
}

fn set_mode(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

fn wait_for(mut ready: impl FnMut() -> bool, what: &str) {
    let started = Instant::now();
    while !ready() {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn the_slurm_job_array_example_renders_every_chunk() {
    if let Some(missing) = TOOLS.iter().find(|t| find(t).is_none()) {
        eprintln!(
            "SKIPPED: `{missing}` is not installed. This test runs docs/examples/slurm-render.sh on a \
             private single-node Slurm; install it with \
             `apt-get install slurmctld slurmd slurm-client munge` (CI does)."
        );
        return;
    }
    // The scene, read in place from the shared folder.
    let Some(scene) = common::shared::sample("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let cluster = Cluster::start();
    let work = cluster.dir.path().join("work");
    let out = work.join("frames");
    std::fs::create_dir_all(&out).unwrap();
    // Chunk 2 (frames 4-5) fails: frame 5's EXR name is taken by a directory.
    std::fs::create_dir_all(out.join("BoxAnimated.0005.exr")).unwrap();
    let bin_dir = Path::new(common::SOUPRAY).parent().unwrap().to_path_buf();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let script = common::repo().join("docs/examples/slurm-render.sh");
    let submitted = cluster
        .client("sbatch")
        .args(["--parsable", "--array=0-3", "--chdir"])
        .arg(&work)
        .arg(format!("--output={}/task-%a.log", work.display()))
        .arg("--export=ALL")
        .arg(&script)
        .env("PATH", &path)
        .env("SCENE", &scene)
        .env("OUT", &out)
        .env("FIRST", "0")
        .env("LAST", "6")
        .env("CHUNK", "2")
        .env("SPP", "1")
        .env("SOUPRAY_ARGS", "--width 32 --height 18")
        .output()
        .unwrap();
    assert!(
        submitted.status.success(),
        "{}",
        String::from_utf8_lossy(&submitted.stderr)
    );
    let job = String::from_utf8_lossy(&submitted.stdout)
        .trim()
        .to_string();
    let finished = |t: &[(u32, String, String)]| {
        t.len() == 4
            && t.iter().all(|(_, s, _)| {
                matches!(s.as_str(), "COMPLETED" | "FAILED" | "CANCELLED" | "TIMEOUT")
            })
    };
    let started = Instant::now();
    let mut tasks = cluster.tasks(&job);
    while !finished(&tasks) {
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "tasks did not finish: {tasks:?}"
        );
        std::thread::sleep(Duration::from_millis(500));
        tasks = cluster.tasks(&job);
    }
    let state = |id: u32| tasks.iter().find(|t| t.0 == id).cloned().unwrap();
    for id in [0, 1, 3] {
        assert_eq!(state(id).1, "COMPLETED", "task {id}: {tasks:?}");
    }
    assert_eq!(
        state(2).1,
        "FAILED",
        "the failing chunk must show as failed: {tasks:?}"
    );
    assert_eq!(state(2).2, "5:0", "a frame failure exits 5: {tasks:?}");
    // Every frame of the good chunks (0-3 and 6) and frame 4 of the failed
    // one are complete; no temporaries are left anywhere.
    for frame in [0, 1, 2, 3, 4, 6] {
        let exr = out.join(format!("BoxAnimated.{frame:04}.exr"));
        assert!(
            soupray::output::is_complete_exr(&exr),
            "{} missing",
            exr.display()
        );
        assert!(out.join(format!("BoxAnimated.{frame:04}.json")).is_file());
    }
    let leftovers: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    let log = std::fs::read_to_string(work.join("task-2.log")).unwrap();
    assert!(
        log.contains("frame 5"),
        "the failed task's log names the frame: {log}"
    );
}
