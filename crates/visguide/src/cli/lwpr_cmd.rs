//! `visguide lwpr fit` / `visguide lwpr predict`: incremental LWPR on a CSV table.

use std::io::Write;
use std::path::PathBuf;

use clap::{Args, Subcommand};
use visguide::models::LwprFile;
use visguide::output::atomic::write_atomic;
use visguide::tables::{self, cell};

use super::CliResult;
use super::common::{Ui, check_outputs};

/// Learn a regression with LWPR (Vijayakumar et al. 2005), or predict with a learned one.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  visguide lwpr fit arm.csv --inputs 2 --model arm.lwpr.json --passes 20
  visguide lwpr predict arm.lwpr.json new-poses.csv --out predictions.csv")]
pub struct LwprArgs {
    #[command(subcommand)]
    pub command: LwprCommand,
}

/// The two steps.
#[derive(Subcommand, Debug)]
pub enum LwprCommand {
    /// Fit a model to DATA.csv: the first --inputs columns are inputs, the rest outputs.
    ///
    /// Rows are fed to the incremental learner in file order, --passes times. Inputs and
    /// outputs are normalised by their standard deviation over the table (norm_in / norm_out).
    /// The model is written to --model (JSON, versioned); a summary (training nMSE per output,
    /// receptive fields) goes to stderr.
    Fit(FitArgs),
    /// Predict for every row of DATA.csv (its first n_in columns; further columns are ignored).
    ///
    /// Writes CSV: the inputs, then per output its prediction, its confidence bound
    /// (`<name>_conf`, infinite where no trustworthy receptive field is active) and its
    /// derivatives `d<name>/d<input>` (the analytic Jacobian).
    Predict(PredictArgs),
}

/// `lwpr fit`.
#[derive(Args, Debug)]
pub struct FitArgs {
    /// The table (comma-separated numbers; an optional header line of column names).
    pub data: PathBuf,
    /// Number of input columns (the first ones).
    #[arg(long, value_name = "N")]
    pub inputs: usize,
    /// Where the model goes.
    #[arg(long, default_value = "model.lwpr.json", value_name = "FILE")]
    pub model: PathBuf,
    /// Passes over the table.
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub passes: usize,
    /// Initial distance metric D = d·I (in normalised units; larger d: narrower fields).
    #[arg(long, default_value_t = 25.0, value_name = "d")]
    pub init_d: f64,
    /// Activation below which a new receptive field is created.
    #[arg(long, default_value_t = 0.2, value_name = "W")]
    pub w_gen: f64,
    /// Learn the distance metric with meta learning (IDBD).
    #[arg(long)]
    pub meta: bool,
}

/// `lwpr predict`.
#[derive(Args, Debug)]
pub struct PredictArgs {
    /// A model written by `lwpr fit`.
    pub model: PathBuf,
    /// The table of inputs.
    pub data: PathBuf,
    /// Output CSV (default: standard output).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Activation cutoff of the prediction.
    #[arg(long, default_value_t = 0.001)]
    pub cutoff: f64,
}

fn std_dev(rows: &[Vec<f64>], c: usize) -> f64 {
    let n = rows.len() as f64;
    let mean = rows.iter().map(|r| r[c]).sum::<f64>() / n;
    let var = rows.iter().map(|r| (r[c] - mean).powi(2)).sum::<f64>() / n;
    if var.sqrt() > 1e-12 { var.sqrt() } else { 1.0 }
}

/// Runs the subcommand.
pub fn run(a: &LwprArgs, ui: Ui) -> CliResult {
    match &a.command {
        LwprCommand::Fit(f) => fit(f, ui),
        LwprCommand::Predict(p) => predict(p, ui),
    }
}

fn fit(a: &FitArgs, ui: Ui) -> CliResult {
    check_outputs(&[&a.model], &[&a.data], false)?;
    let t = tables::read(&a.data)?;
    let width = t.columns.len();
    if a.inputs == 0 || a.inputs >= width {
        return Err(format!(
            "{}: --inputs {} leaves no output column ({} columns in the table)",
            a.data.display(),
            a.inputs,
            width
        )
        .into());
    }
    if a.passes == 0 {
        return Err("--passes must be at least 1".into());
    }
    let updates = a
        .passes
        .checked_mul(t.rows.len())
        .and_then(|u| u64::try_from(u).ok())
        .ok_or_else(|| {
            format!(
                "--passes {} × {} rows is more than 2^64 updates",
                a.passes,
                t.rows.len()
            )
        })?;
    let (n, m) = (a.inputs, width - a.inputs);
    // LWPR's bound on its inputs and outputs, checked here so the error names the cell (the
    // standard deviations below would overflow first, and the builder's error name no file).
    for (row, line) in t.rows.iter().zip(&t.lines) {
        if let Some((c, v)) = row
            .iter()
            .enumerate()
            .find(|(_, v)| v.abs() > lwpr::MAX_ABS_VALUE)
        {
            return Err(format!(
                "{}:{line}: column `{}` = {v:e} exceeds LWPR's bound of {:e} on inputs and \
                 outputs",
                a.data.display(),
                t.columns[c],
                lwpr::MAX_ABS_VALUE
            )
            .into());
        }
    }
    let norm_in: Vec<f64> = (0..n).map(|c| std_dev(&t.rows, c)).collect();
    let norm_out: Vec<f64> = (n..width).map(|c| std_dev(&t.rows, c)).collect();
    let mut model = lwpr::LwprBuilder::new(n, m)
        .norm_in(&norm_in)
        .norm_out(&norm_out)
        .init_d_spherical(a.init_d)
        .w_gen(a.w_gen)
        .meta(a.meta)
        .build()
        .map_err(|e| format!("LWPR setting: {e}"))?;
    let bar = ui.bar(updates, "lwpr fit");
    for _ in 0..a.passes {
        for (row, line) in t.rows.iter().zip(&t.lines) {
            model
                .update(&row[..n], &row[n..])
                .map_err(|e| format!("{}:{line}: {e}", a.data.display()))?;
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    // Training error per output.
    let mut sse = vec![0.0; m];
    for (row, line) in t.rows.iter().zip(&t.lines) {
        let y = model
            .predict(&row[..n], 0.001)
            .map_err(|e| format!("{}:{line}: {e}", a.data.display()))?;
        for o in 0..m {
            sse[o] += (y[o] - row[n + o]).powi(2);
        }
    }
    let file = LwprFile::new(t.columns[..n].to_vec(), t.columns[n..].to_vec(), &model)?;
    file.save(&a.model)?;
    let nmse: Vec<String> = (0..m)
        .map(|o| {
            let var = std_dev(&t.rows, n + o).powi(2);
            format!(
                "{} {:.4}",
                t.columns[n + o],
                sse[o] / t.rows.len() as f64 / var
            )
        })
        .collect();
    ui.say(format!(
        "{} rows × {} passes; receptive fields {:?}; training nMSE: {} → {}",
        t.rows.len(),
        a.passes,
        model.num_rfs(),
        nmse.join(", "),
        a.model.display()
    ));
    Ok(())
}

fn predict(a: &PredictArgs, ui: Ui) -> CliResult {
    check_outputs(a.out.as_slice(), &[&a.model, &a.data], false)?;
    let (file, model) = LwprFile::load(&a.model)?;
    let t = tables::read(&a.data)?;
    let n = model.n_in();
    if t.columns.len() < n {
        return Err(format!(
            "{}: {} columns, but the model has {} inputs",
            a.data.display(),
            t.columns.len(),
            n
        )
        .into());
    }
    let mut header: Vec<String> = file.inputs.clone();
    for o in &file.outputs {
        header.push(o.clone());
        header.push(format!("{o}_conf"));
        for i in &file.inputs {
            header.push(format!("d{o}/d{i}"));
        }
    }
    let mut lines = Vec::with_capacity(t.rows.len());
    for (row, line) in t.rows.iter().zip(&t.lines) {
        let x = &row[..n];
        let err = |e: lwpr::LwprError| format!("{}:{line}: {e}", a.data.display());
        let c = model.predict_with_confidence(x, a.cutoff).map_err(err)?;
        let j = model.predict_with_jacobian(x, a.cutoff).map_err(err)?;
        let mut cells: Vec<String> = x.iter().map(|v| cell(*v)).collect();
        for o in 0..model.n_out() {
            cells.push(cell(c.y[o]));
            cells.push(cell(c.confidence[o]));
            for i in 0..n {
                cells.push(cell(j.jacobian[(o, i)]));
            }
        }
        lines.push(cells.join(","));
    }
    let fill = |w: &mut dyn Write| -> visguide::Result<()> {
        let io = |e| visguide::VisguideError::Io {
            path: a.out.clone().unwrap_or_else(|| "<stdout>".into()),
            source: e,
        };
        writeln!(w, "{}", header.join(",")).map_err(io)?;
        for l in &lines {
            writeln!(w, "{l}").map_err(io)?;
        }
        Ok(())
    };
    match &a.out {
        Some(p) => write_atomic(p, fill)?,
        None => fill(&mut std::io::stdout().lock())?,
    }
    ui.say(format!("{} predictions", lines.len()));
    Ok(())
}
