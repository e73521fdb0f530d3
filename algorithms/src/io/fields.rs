//! Point arrays turned into a mesh's named fields, which every reader shares: arrays named
//! `name_t000`, `name_t001`, … grouped as the time steps of `name`, and the active field chosen.

use crate::error::{Error, Result};
use crate::mesh::{Field, Mesh};

/// `name_t012` → (`name`, 12).
fn time_step_name(name: &str) -> Option<(&str, usize)> {
    let i = name.rfind("_t")?;
    let digits = &name[i + 2..];
    if i == 0
        || digits.is_empty()
        || digits.len() > 9
        || !digits.bytes().all(|b| b.is_ascii_digit())
    {
        return None;
    }
    Some((&name[..i], digits.parse().ok()?))
}

/// The array name a writer gives step `k` of a field with `n` steps.
pub fn step_name(name: &str, k: usize, n: usize) -> String {
    if n <= 1 {
        return name.to_string();
    }
    let width = (n - 1).to_string().len().max(3);
    format!("{name}_t{k:0width$}")
}

/// Named 1-component point arrays, in file order, to fields: names repeated get a `_2`, `_3`…
/// suffix; two or more arrays `base_t000`, `base_t001`, … numbered 0..n without gaps become one
/// field `base` with n time steps, placed where its first step was.
pub fn make_fields(arrays: Vec<(String, Vec<f64>)>) -> Vec<Field> {
    let mut named: Vec<(String, Vec<f64>)> = Vec::with_capacity(arrays.len());
    for (name, v) in arrays {
        let mut n = name.clone();
        let mut k = 2;
        while named.iter().any(|(m, _)| *m == n) {
            n = format!("{name}_{k}");
            k += 1;
        }
        named.push((n, v));
    }
    // Which bases form complete step sequences?
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, (name, _)) in named.iter().enumerate() {
        if let Some((base, _)) = time_step_name(name) {
            match groups.iter_mut().find(|(b, _)| b == base) {
                Some(g) => g.1.push(i),
                None => groups.push((base.to_string(), vec![i])),
            }
        }
    }
    let mut grouped: Vec<Option<usize>> = vec![None; named.len()]; // array → group index
    let mut good: Vec<(String, Vec<usize>)> = Vec::new();
    for (base, members) in groups {
        let mut steps: Vec<(usize, usize)> = members
            .iter()
            .map(|&i| (time_step_name(&named[i].0).map_or(0, |x| x.1), i))
            .collect();
        steps.sort_unstable();
        let complete = steps.len() >= 2
            && steps.iter().enumerate().all(|(k, &(s, _))| s == k)
            && !named.iter().any(|(n, _)| *n == base);
        if complete {
            for &(_, i) in &steps {
                grouped[i] = Some(good.len());
            }
            good.push((base, steps.into_iter().map(|(_, i)| i).collect()));
        }
    }
    let mut values: Vec<Option<Vec<f64>>> = named
        .iter_mut()
        .map(|(_, v)| Some(std::mem::take(v)))
        .collect();
    let mut fields = Vec::new();
    for i in 0..named.len() {
        match grouped[i] {
            None => fields.push(Field {
                name: named[i].0.clone(),
                steps: vec![values[i].take().unwrap_or_default()],
            }),
            // A group goes where its first array (in file order) was.
            Some(g) if good[g].1.iter().min() == Some(&i) => {
                let steps = good[g]
                    .1
                    .iter()
                    .map(|&j| values[j].take().unwrap_or_default())
                    .collect();
                fields.push(Field {
                    name: good[g].0.clone(),
                    steps,
                });
            }
            Some(_) => {}
        }
    }
    fields
}

/// Finds a field by name, also as `base_tNNN` for step NNN of a field with steps.
pub fn find_field(fields: &[Field], name: &str) -> Option<(String, usize)> {
    if let Some(f) = fields.iter().find(|f| f.name == name) {
        return Some((f.name.clone(), 0));
    }
    let (base, k) = time_step_name(name)?;
    fields
        .iter()
        .find(|f| f.name == base && f.steps.len() > k)
        .map(|f| (f.name.clone(), k))
}

/// Makes `wanted` (the user's choice: refused when unknown) or else `default` (the file's
/// choice: ignored when unknown) the active field.
pub fn select_active(
    mesh: &mut Mesh,
    source: &str,
    wanted: Option<&str>,
    default: Option<&str>,
) -> Result<()> {
    if let Some(w) = wanted {
        let Some((name, k)) = find_field(mesh.fields(), w) else {
            let known: Vec<&str> = mesh.fields().iter().map(|f| f.name.as_str()).collect();
            return Err(Error::input(
                source,
                format!("no point field '{w}' (fields: {})", known.join(", ")),
            ));
        };
        return mesh.select_field(&name, k);
    }
    if let Some((name, k)) = default.and_then(|d| find_field(mesh.fields(), d)) {
        mesh.select_field(&name, k)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_steps_are_grouped() {
        let a = |n: &str, v: f64| (n.to_string(), vec![v]);
        let f = make_fields(vec![
            a("p", 0.0),
            a("T_t001", 2.0),
            a("T_t000", 1.0),
            a("q_t000", 3.0),
            a("p", 4.0),
            a("r_t000", 5.0),
            a("r_t002", 6.0),
        ]);
        let names: Vec<&str> = f.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["p", "T", "q_t000", "p_2", "r_t000", "r_t002"]);
        assert_eq!(f[1].steps, vec![vec![1.0], vec![2.0]]);
        assert_eq!(step_name("T", 1, 2), "T_t001");
        assert_eq!(step_name("T", 0, 1), "T");
        assert_eq!(find_field(&f, "T_t001"), Some(("T".into(), 1)));
    }
}
