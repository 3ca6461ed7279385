//! Writing the reference library's XML layout (`lwpr_write_xml`): the same elements, names and
//! row-by-row matrix layout, with every number in Rust's shortest round-trip form (`{:e}`), so a
//! file holds the model exactly (the reference prints six decimals).

use std::fmt::Write;

use crate::model::Lwpr;
use crate::params::{Arithmetic, Kernel, PruneRule};
use crate::rf::ReceptiveField;

struct Out(String);

impl Out {
    fn tabs(&mut self, level: usize) {
        for _ in 0..level {
            self.0.push('\t');
        }
    }
    fn int(&mut self, level: usize, name: &str, v: impl std::fmt::Display) {
        self.tabs(level);
        let _ = writeln!(self.0, "<integer name='{name}'> {v} </integer>");
    }
    fn scalar(&mut self, level: usize, name: &str, v: f64) {
        self.tabs(level);
        let _ = writeln!(self.0, "<scalar name='{name}'> {v:e} </scalar>");
    }
    fn vector(&mut self, level: usize, name: &str, v: &[f64]) {
        self.tabs(level);
        let _ = writeln!(self.0, "<vector name='{name}' length='{}'>", v.len());
        for x in v {
            self.tabs(level);
            let _ = writeln!(self.0, " {x:e}");
        }
        self.tabs(level);
        self.0.push_str("</vector>\n");
    }
    /// A column-major `rows × cols` matrix, one row per line (the reference's layout).
    fn matrix(&mut self, level: usize, name: &str, rows: usize, cols: usize, v: &[f64]) {
        self.tabs(level);
        let _ = writeln!(
            self.0,
            "<matrix name='{name}' rows='{rows}' columns='{cols}'>"
        );
        for i in 0..rows {
            self.tabs(level);
            for j in 0..cols {
                let _ = write!(self.0, " {:e}", v[i + j * rows]);
            }
            self.0.push('\n');
        }
        self.tabs(level);
        self.0.push_str("</matrix>\n");
    }
    fn rf(&mut self, n: usize, rf: &ReceptiveField) {
        let r = rf.n_reg;
        let _ = writeln!(self.0, "\t\t<ReceptiveField nReg='{r}'>");
        self.matrix(3, "D", n, n, &rf.d);
        self.matrix(3, "M", n, n, &rf.m);
        self.matrix(3, "alpha", n, n, &rf.alpha);
        self.scalar(3, "beta0", rf.beta0);
        self.vector(3, "beta", &rf.beta);
        self.vector(3, "c", &rf.c);
        self.matrix(3, "SXresYres", n, r, &rf.sxy);
        self.vector(3, "SSs2", &rf.ss_s2);
        self.vector(3, "SSYres", &rf.ss_y);
        self.matrix(3, "SSXres", n, r, &rf.ssx);
        self.matrix(3, "U", n, r, &rf.u);
        self.matrix(3, "P", n, r, &rf.p);
        self.vector(3, "H", &rf.tr_h);
        self.vector(3, "r", &rf.tr_r);
        self.matrix(3, "h", n, n, &rf.h);
        self.matrix(3, "b", n, n, &rf.b);
        self.vector(3, "sum_w", &rf.sum_w);
        self.vector(3, "sum_e_cv2", &rf.sum_e_cv2);
        self.scalar(3, "sum_e2", rf.sum_e2);
        self.scalar(3, "SSp", rf.ssp);
        self.vector(3, "n_data", &rf.n_data);
        self.int(3, "trustworthy", rf.trustworthy as u8);
        self.vector(3, "lambda", &rf.lambda);
        self.vector(3, "mean_x", &rf.mean_x);
        self.vector(3, "var_x", &rf.var_x);
        self.scalar(3, "w", rf.w);
        self.vector(3, "s", &rf.s);
        self.0.push_str("\t\t</ReceptiveField>\n");
    }
}

/// The name of a kernel in the file (the reference's spelling).
pub(super) fn kernel_name(k: Kernel) -> &'static str {
    match k {
        Kernel::Gaussian => "Gaussian",
        Kernel::BiSquare => "BiSquare",
    }
}

/// The name of a pruning rule in the `prune_rule` attribute.
pub(super) fn prune_name(r: PruneRule) -> &'static str {
    match r {
        PruneRule::ReferenceC => "ReferenceC",
        PruneRule::Published => "Published",
    }
}

/// The name of an arithmetic in the `arithmetic` attribute.
pub(super) fn arithmetic_name(a: Arithmetic) -> &'static str {
    match a {
        Arithmetic::Fast => "Fast",
        Arithmetic::Reference => "Reference",
    }
}

/// The whole document.
pub(super) fn to_xml(model: &Lwpr) -> String {
    let p = &model.params;
    let n = p.n_in;
    let mut o = Out(String::with_capacity(4096));
    o.0.push_str("<?xml version='1.0' encoding='US-ASCII' ?>\n");
    // The reference reads `nIn`, `nOut` and `kernel` and ignores other attributes silently.
    let _ = writeln!(
        o.0,
        "<LWPR nIn='{n}' nOut='{}' kernel='{}' prune_rule='{}' arithmetic='{}'>",
        p.n_out,
        kernel_name(p.kernel),
        prune_name(p.prune_rule),
        arithmetic_name(p.arithmetic)
    );
    o.int(1, "n_data", model.n_data);
    o.vector(1, "mean_x", &model.mean_x);
    o.vector(1, "var_x", &model.var_x);
    o.int(1, "diag_only", p.diag_only as u8);
    o.int(1, "update_D", p.update_d as u8);
    o.int(1, "meta", p.meta as u8);
    o.scalar(1, "meta_rate", p.meta_rate);
    o.scalar(1, "penalty", p.penalty);
    o.matrix(1, "init_alpha", n, n, &p.init_alpha);
    o.vector(1, "norm_in", &p.norm_in);
    o.vector(1, "norm_out", &p.norm_out);
    o.matrix(1, "init_D", n, n, &p.init_d);
    o.matrix(1, "init_M", n, n, &p.init_m);
    o.scalar(1, "w_gen", p.w_gen);
    o.scalar(1, "w_prune", p.w_prune);
    o.scalar(1, "init_lambda", p.init_lambda);
    o.scalar(1, "final_lambda", p.final_lambda);
    o.scalar(1, "tau_lambda", p.tau_lambda);
    o.scalar(1, "init_S2", p.init_s2);
    o.scalar(1, "add_threshold", p.add_threshold);
    for (dim, sub) in model.sub.iter().enumerate() {
        let _ = writeln!(
            o.0,
            "\t<SubModel out_dim='{dim}' numRFS='{}'>",
            sub.rfs.len()
        );
        o.int(2, "n_pruned", sub.n_pruned);
        for rf in &sub.rfs {
            o.rf(n, rf);
        }
        o.0.push_str("\t</SubModel>\n");
    }
    o.0.push_str("</LWPR>\n");
    o.0
}
