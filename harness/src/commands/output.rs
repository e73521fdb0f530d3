//! How the commands print their results: `name: value` lines or one JSON object.

use serde_json::{json, Map, Value};

use crate::table;

/// Prints `name: value` lines, or one JSON object.
pub(super) fn print_pairs<'a>(pairs: impl IntoIterator<Item = (&'a str, Value)>, as_json: bool) {
    let pairs: Vec<(&str, Value)> = pairs.into_iter().collect();
    if as_json {
        let mut m = Map::new();
        for (k, v) in pairs {
            m.insert(k.to_string(), v);
        }
        println!("{}", Value::Object(m));
    } else {
        for (k, v) in pairs {
            match v {
                Value::String(s) => println!("{k}: {s}"),
                Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
                    (Some(u), _, _) => println!("{k}: {u}"),
                    (_, Some(i), _) => println!("{k}: {i}"),
                    (_, _, Some(f)) => println!("{k}: {}", table::plain(f)),
                    _ => println!("{k}: {n}"),
                },
                // serde_json turns inf and NaN into null (numbers go through `num`, which
                // keeps them as "inf" and "NaN").
                Value::Null => println!("{k}: null"),
                other => println!("{k}: {other}"),
            }
        }
    }
}

/// A float for output: inf and NaN become the strings "inf", "-inf" and "NaN" rather than
/// JSON's null.
pub(super) fn num(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}
