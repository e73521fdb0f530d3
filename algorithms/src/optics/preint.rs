//! `preint`: full pre-integration, a lookup in a [`PreintTable`] built for the transfer
//! function (CONVENTIONS §4, `preint` row).

use std::sync::Arc;

use super::preint_table::PreintTable;
use super::{Integrator, IntegratorInfo, Segment};
use crate::tf::TransferFunction;

/// `preint`.
pub const PREINT: IntegratorInfo = IntegratorInfo {
    name: "preint",
    description: "full pre-integration: a table over (s_f, s_b, l) (Röttger et al. 2000)",
    on_gpu: true,
    make: |tf| Box::new(Preint::new(tf)),
};

/// `preint`: lookup in a [`PreintTable`] built for the transfer function.
#[derive(Clone, Debug)]
pub struct Preint {
    table: Arc<PreintTable>,
}

impl Preint {
    /// The default-resolution table for `tf`: rebuilt only when the transfer function changes
    /// (the last one built is kept, so a run over many meshes and views builds it once).
    pub fn new(tf: &TransferFunction) -> Preint {
        static LAST: std::sync::Mutex<Option<(TransferFunction, Arc<PreintTable>)>> =
            std::sync::Mutex::new(None);
        let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((t, table)) = last.as_ref() {
            if t == tf {
                return Preint {
                    table: table.clone(),
                };
            }
        }
        let table = Arc::new(PreintTable::new(tf));
        *last = Some((tf.clone(), table.clone()));
        Preint { table }
    }
    pub fn with_table(table: Arc<PreintTable>) -> Preint {
        Preint { table }
    }
    pub fn table(&self) -> &PreintTable {
        &self.table
    }
}

impl Integrator for Preint {
    fn name(&self) -> &'static str {
        "preint"
    }
    fn segment(&self, sf: f64, sb: f64, l: f64) -> Segment {
        self.table.lookup(sf, sb, l)
    }
}
