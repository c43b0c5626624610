//! Checks the outputs of `ema` against `docs/output-schema.md`: every JSON key and CSV column a
//! command writes is documented there, and every documented one is written.
//!
//! A section of the page is a `## HEADING` followed by a table whose first column is the key (in
//! backticks) and whose second is its type: `optional` in the type marks a key present only in
//! some cases, a type starting with `map` an object with free keys (not descended into), and
//! `k{1..8}_true` stands for eight columns.
#![allow(dead_code)]

use std::collections::BTreeSet;

/// One documented key.
#[derive(Debug, Clone)]
pub struct Row {
    /// The key path (`a`, `a.b`, `a[].b`) or CSV column.
    pub key: String,
    /// Present only in some cases.
    pub optional: bool,
    /// An object with free keys.
    pub map: bool,
}

/// The schema page.
pub fn page() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/output-schema.md");
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// `k{1..8}_true` as its eight keys; any other key as itself.
fn expand(key: &str) -> Vec<String> {
    match (key.find("{1..8}"), key.len()) {
        (Some(i), _) => (1..=8).map(|n| format!("{}{n}{}", &key[..i], &key[i + 6..])).collect(),
        (None, _) => vec![key.to_string()],
    }
}

/// The rows of the table under `## heading`, in order.
pub fn section(heading: &str) -> Vec<Row> {
    let page = page();
    let mut lines = page.lines().skip_while(|l| l.trim() != format!("## {heading}"));
    assert!(lines.next().is_some(), "no section '## {heading}' in docs/output-schema.md");
    let mut rows = Vec::new();
    for line in lines.take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 || !cells[1].starts_with('`') {
            continue;
        }
        let key = cells[1].trim_matches('`');
        for key in expand(key) {
            rows.push(Row { key, optional: cells[2].contains("optional"), map: cells[2].starts_with("map") });
        }
    }
    assert!(!rows.is_empty(), "section '{heading}' has no table");
    rows
}

/// Every key path of `v` (objects: `a.b`, arrays of objects or arrays: `a[].b`) into `paths`,
/// and every such array seen with elements into `filled`; the keys of `maps` are not descended.
fn flatten(
    v: &serde_json::Value,
    prefix: &str,
    maps: &BTreeSet<String>,
    paths: &mut BTreeSet<String>,
    filled: &mut BTreeSet<String>,
) {
    match v {
        serde_json::Value::Object(o) => {
            for (k, x) in o {
                let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                paths.insert(path.clone());
                if !maps.contains(&path) {
                    flatten(x, &path, maps, paths, filled);
                }
            }
        }
        serde_json::Value::Array(a) if a.iter().any(|x| x.is_object() || x.is_array()) => {
            let path = format!("{prefix}[]");
            filled.insert(path.clone());
            for x in a {
                flatten(x, &path, maps, paths, filled);
            }
        }
        _ => {}
    }
}

/// Checks JSON documents of one command (several runs, so that optional keys can be seen) against
/// the section `heading`: the envelope, every key documented, every key that is not optional
/// present (unless it lives in an array that was empty in every run).
pub fn check_json(heading: &str, docs: &[&serde_json::Value]) {
    let rows = section(heading);
    let documented: BTreeSet<String> = rows.iter().map(|r| r.key.clone()).collect();
    let maps: BTreeSet<String> = rows.iter().filter(|r| r.map).map(|r| r.key.clone()).collect();
    let (mut paths, mut filled) = (BTreeSet::new(), BTreeSet::new());
    for v in docs {
        assert_eq!(v["schema_version"], 1, "{v}");
        assert_eq!(v["tool_version"].as_str(), Some(env!("CARGO_PKG_VERSION")), "{v}");
        flatten(v, "", &maps, &mut paths, &mut filled);
    }
    let undocumented: Vec<&String> = paths.difference(&documented).collect();
    assert!(undocumented.is_empty(), "{heading}: keys missing from docs/output-schema.md: {undocumented:?}");
    let missing: Vec<&String> = rows
        .iter()
        .filter(|r| !r.optional && !paths.contains(&r.key))
        .filter(|r| r.key.rfind("[]").is_none_or(|i| filled.contains(&r.key[..i + 2])))
        .map(|r| &r.key)
        .collect();
    assert!(missing.is_empty(), "{heading}: documented keys not written: {missing:?}");
}

/// Checks a CSV file's header against the section `heading`: the documented columns, in order.
pub fn check_csv(heading: &str, csv: &str) {
    let header: Vec<&str> = csv.lines().next().unwrap_or_default().split(',').collect();
    let documented: Vec<String> = section(heading).into_iter().map(|r| r.key).collect();
    assert_eq!(header, documented, "{heading}: the header and docs/output-schema.md differ");
}
