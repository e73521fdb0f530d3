//! Command-line definitions (clap). Names and flags of CONVENTIONS §8 are fixed.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::meshes::MeshSpec;

#[derive(Parser, Debug)]
#[command(
    name = "tetbench",
    version,
    about = "Benchmark volume renderers for unstructured tetrahedral meshes side by side",
    after_help = "Examples:
  tetbench info blunt
  tetbench info mesh.vtu --json
  tetbench render post --renderer reference --size 512x512 --view 30,20 --out post.exr
  tetbench render spx --renderer raycast --integrator partial --out spx.png
  tetbench compare test.exr reference.exr
  tetbench list

MESH is a file (.off, .vtk, .vtu, PLOT3D *xyz*), one of the NASA grids blunt, post, comb
(looked up in $TETBENCH_DATA, else ../shared/datasets), or a datasets-gen name, optionally
with a size: spx, fighter:200000, hard-slivers."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Print a mesh's size, scalar range, bounding box, degenerate tets, boundary and convexity.
    #[command(after_help = "Example: tetbench info post --json")]
    Info {
        #[command(flatten)]
        mesh: MeshArgs,
        /// Print one JSON object instead of `name: value` lines.
        #[arg(long)]
        json: bool,
    },
    /// Write the tets tetbench renders for MESH as .vtu, .vtk or .off: the NASA grids with their
    /// 5-tet split, generated meshes, every field with the active one marked.
    #[command(
        after_help = "Examples: tetbench convert blunt blunt.vtu; tetbench convert fighter:200000 fighter.vtk

.vtu (VTK XML) and .vtk (VTK legacy 5.1, binary) hold every field, each time step as
name_tNNN, the active one as the point data's scalars; .off holds the active field only.
ParaView and VTK then show the same tets tetbench renders. The file is written under a
temporary name and renamed, so a failed write leaves nothing behind."
    )]
    Convert {
        #[command(flatten)]
        mesh: MeshArgs,
        /// Output file: .vtu, .vtk or .off.
        out: PathBuf,
    },
    /// Render one image.
    #[command(
        after_help = "Example: tetbench render blunt --renderer reference --view 0,0 --size 256x256 --out blunt.exr"
    )]
    Render(Box<RenderArgs>),
    /// Compare a test image against a reference image (CONVENTIONS §6).
    #[command(after_help = "Example: tetbench compare cpu-pt.exr reference.exr --json")]
    Compare {
        /// The image under test (.exr or .png).
        test: PathBuf,
        /// The reference image (.exr or .png).
        reference: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// List renderers, sorts, integrators, transfer-function presets and datasets.
    #[command(after_help = "Example: tetbench list --peers peers/examples/peers.toml")]
    List(ListArgs),
    /// Run an experiment file: datasets x renderers x sorts x integrators x sizes x views.
    #[command(
        after_help = "Example: tetbench bench harness/experiments/example.toml --out out/example

Writes DIR/results.csv (one row per measurement, flushed as it finishes), DIR/pairs.csv when
pairs are asked for, DIR/meta.txt, the plots (PNG and SVG), the image figure
DIR/results-images.png/.svg (renders and error maps of one cell, from DIR/figure/), the report
DIR/index.html and, with save_images = true, DIR/images/. Reference images are cached in
DIR/.cache by content hash. Keys: docs/experiments.md; figures and report: docs/report.md"
    )]
    Bench {
        /// The experiment file (TOML).
        config: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Do not draw plots.
        #[arg(long)]
        no_plots: bool,
        /// Measure only shard I of N (0 <= I < N) of the measurement matrix, balanced by
        /// estimated cost (tets x pixels x frames); merge the shards with `tetbench merge`.
        #[arg(long, value_name = "I/N")]
        shard: Option<String>,
        /// Measure only the rows not yet in DIR/results.csv (a run that was interrupted).
        #[arg(long, conflicts_with = "force")]
        resume: bool,
        /// Discard the results already in DIR and start again.
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        peers: PeersArg,
        /// Run the peers declared in the experiment file itself ([[peer]] tables start
        /// programs: without this flag such a file is refused).
        #[arg(long)]
        allow_peers: bool,
    },
    /// Merge the directories of `tetbench bench --shard I/N` runs into one, and draw the plots.
    #[command(
        after_help = "Example: tetbench merge --out out/all out/shard0 out/shard1 out/shard2

The shards must come from the same experiment file, the same N and the same tetbench version,
and together hold every row of the sweep exactly once; anything else is refused, naming the
shard. The output directory must not be a shard, and results already in it are replaced only
with --force. The merge also draws the image figure (results-images.png/.svg) and writes
DIR/index.html."
    )]
    Merge {
        /// Output directory for the merged results.csv and plots.
        #[arg(long)]
        out: PathBuf,
        /// The shard directories.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Do not draw plots.
        #[arg(long)]
        no_plots: bool,
        /// Replace the results already in the output directory.
        #[arg(long)]
        force: bool,
    },
    /// Regenerate the papers' tables (PTINT Table 1, 2, Fig. 8; HAPT Tables 1-4; JBU Fig. 3-5;
    /// BCC §3 and §4) and their plots.
    #[command(after_help = "Examples: tetbench reproduce --quick --out results-quick
          tetbench reproduce --only jbu --out results

Each table is written as DIR/<table>.csv and DIR/<table>.md beside the paper's figures, with
its plots and its image figure DIR/<table>-images.png/.svg; raw measurements under
DIR/raw/<table>/. DIR/index.html is the report of every table (docs/report.md). Tables whose renderers are not registered
yet are skipped with a note in DIR/README.md. The joint bilateral upsampling study is the
table `jbu` (`--only jbu`; there is no separate `tetbench jbu` command); BCC's are `bcc_pt`
and `bcc_reconstruction`.")]
    Reproduce {
        /// Smaller meshes, fewer views, smaller images (minutes on 2 cores).
        #[arg(long)]
        quick: bool,
        /// Output directory.
        #[arg(long, default_value = "results")]
        out: PathBuf,
        /// Only these tables (comma-separated ids, see DIR/README.md).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
        /// Measure only shard I of N of every experiment table (raw rows, no tables); the
        /// tables come from `reproduce --merge`.
        #[arg(long, value_name = "I/N", conflicts_with = "merge")]
        shard: Option<String>,
        /// Merge these shard output directories (of `reproduce --shard`) and write the tables.
        #[arg(long, value_name = "SHARD_DIR", num_args = 1..)]
        merge: Vec<std::path::PathBuf>,
        /// Keep the raw rows an interrupted run left under DIR/raw/<table>/ and measure only the
        /// missing ones (tables with image pairs are measured again in full).
        #[arg(long, conflicts_with = "merge")]
        resume: bool,
        /// Print the Slurm commands that run this reproduce as an N-task job array plus a
        /// merge job (submit them, or copy them into your own scripts).
        #[arg(long, value_name = "N")]
        slurm: Option<usize>,
        #[command(flatten)]
        peers: PeersArg,
    },
    /// Redraw the plots of a bench output directory from its results.csv (and pairs.csv), or
    /// of a reproduce directory from its raw/<table>/ rows.
    #[command(after_help = "Examples: tetbench plot out/example; tetbench plot results")]
    Plot {
        /// A directory written by `tetbench bench` or `tetbench reproduce`.
        dir: PathBuf,
    },
    /// Peers: renderers in other programs (docs/peers.md).
    Peer {
        #[command(subcommand)]
        command: PeerCommand,
    },
}

#[derive(Subcommand, Debug)]
pub enum PeerCommand {
    /// The conformance suite: the contract's scenes (convex and non-convex meshes, the hard
    /// cases of the peer's family, ortho and persp, every integrator it offers), each against
    /// `reference` with the bound of docs/peers.md; protocol errors, image sizes, non-finite
    /// pixels, time and memory per frame. Prints a Markdown report; exits 0 only when every
    /// scene passes (3 when some fail).
    #[command(after_help = "Examples:
  tetbench peer check numpy-raycast --peers peers/examples/peers.toml
  tetbench peer check --family pt -- ./my-peer --fast")]
    Check(PeerCheckArgs),
}

/// Peers files named on the command line.
#[derive(Args, Debug, Clone, Default)]
pub struct PeersArg {
    /// A peers file ([[peer]] tables, docs/peers.md); repeatable, added to the files named by
    /// TETBENCH_PEERS (colon-separated).
    #[arg(long = "peers", value_name = "FILE")]
    pub files: Vec<PathBuf>,
}

#[derive(Args, Debug)]
pub struct ListArgs {
    #[command(flatten)]
    pub peers: PeersArg,
}

#[derive(Args, Debug)]
pub struct PeerCheckArgs {
    /// The peer's name (declared in a peers file, or a VTK peer); or give its command after --.
    #[arg(required_unless_present = "command", conflicts_with = "command")]
    pub name: Option<String>,
    #[command(flatten)]
    pub peers: PeersArg,
    /// For a peer given as a command: its family, pt, raycasting or other (default: what its
    /// hello says, else other).
    #[arg(long, requires = "command")]
    pub family: Option<String>,
    /// For a peer given as a command: the deadline of each request, in seconds.
    #[arg(long, default_value_t = 120.0)]
    pub timeout: f64,
    /// Image size of every scene (one more scene is drawn at a non-square size).
    #[arg(long, default_value = "96x96")]
    pub size: String,
    /// Also write the Markdown report to this file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The peer's command and arguments, after `--`.
    #[arg(last = true, value_name = "CMD")]
    pub command: Vec<String>,
}

/// How a mesh is found and read.
#[derive(Args, Debug, Clone)]
pub struct MeshArgs {
    /// Mesh file, short name (blunt, post, comb) or datasets-gen name[:tets].
    pub mesh: String,
    /// Scalar field to use (PLOT3D: density, energy, velocity, momentum-x|y|z).
    #[arg(long)]
    pub scalar: Option<String>,
    /// PLOT3D q file (default: the xyz file name with `xyz` replaced by `q`).
    #[arg(long = "q")]
    pub q_file: Option<PathBuf>,
    /// Split hexahedra (and wedges, pyramids) into tets: 5 or 6 per hex.
    #[arg(long)]
    pub split: Option<u8>,
    /// Read a .off file with 1-based indices.
    #[arg(long)]
    pub one_based: bool,
    /// Seed for datasets-gen meshes (the same default as `datasets-gen --seed`).
    #[arg(long, default_value_t = crate::meshes::DEFAULT_SEED)]
    pub seed: u64,
}

impl MeshArgs {
    /// The plain description of the mesh the rest of the harness works with.
    pub fn to_spec(&self) -> MeshSpec {
        MeshSpec {
            mesh: self.mesh.clone(),
            scalar: self.scalar.clone(),
            q_file: self.q_file.clone(),
            split: self.split,
            one_based: self.one_based,
            seed: self.seed,
            lattice: None,
        }
    }
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Renderer name (see `tetbench list`).
    #[arg(long)]
    pub renderer: String,
    /// Visibility sort (renderers that sort).
    #[arg(long)]
    pub sort: Option<String>,
    /// Integrator: average, partial, preint, exact.
    #[arg(long)]
    pub integrator: Option<String>,
    /// Renderer parameter KEY=VALUE, repeatable (e.g. hapt: mode=iso, iso=0.3,0.7, stream=65536,
    /// timevarying=1).
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
    /// Transfer function: a JSON file or a preset (default, cool-warm, xray).
    #[arg(long, default_value = "default")]
    pub tf: String,
    /// View as AZ,EL in degrees.
    #[arg(long, default_value = "0,0", allow_hyphen_values = true)]
    pub view: String,
    /// ortho or persp.
    #[arg(long, default_value = "ortho")]
    pub projection: String,
    /// Image size WxH.
    #[arg(long, default_value = "512x512")]
    pub size: String,
    /// Output image (.exr or .png).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the timing split as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub peers: PeersArg,
}
