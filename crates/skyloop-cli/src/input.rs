//! Reading what the user names on the command line: models and number lists.

use skyloop_lti::StateSpace;

/// Loads MODEL: a path to an LTI JSON file when such a file exists, else a transfer-function expression.
pub fn load_model(arg: &str) -> Result<StateSpace, String> {
    let path = std::path::Path::new(arg);
    if path.is_file() {
        let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {arg}: {e}"))?;
        return skyloop_lti::json::from_json_str(&text).map_err(|e| format!("{arg}: {e}"));
    }
    if arg.ends_with(".json") {
        return Err(format!("no such file: {arg}"));
    }
    skyloop_lti::expr::parse_model(arg).map_err(|e| format!("'{arg}' is not a file; as an expression: {e}"))
}

/// Parses a comma-separated list of finite numbers such as `0.1,1,10`.
#[allow(dead_code)]
pub fn parse_list(text: &str, what: &str) -> Result<Vec<f64>, String> {
    text.split(',')
        .map(|t| {
            let v: f64 = t.trim().parse().map_err(|_| format!("{what}: '{t}' is not a number"))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(format!("{what}: '{t}' is not finite"))
            }
        })
        .collect()
}
