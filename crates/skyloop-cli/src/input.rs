//! Reading number lists the user names on the command line (models are read by
//! [`skyloop::model::load_model`]).

/// Parses a comma-separated list of finite numbers such as `0.1,1,10`.
pub fn parse_list(text: &str, what: &str) -> skyloop::Result<Vec<f64>> {
    text.split(',')
        .map(|t| {
            let v: f64 = t
                .trim()
                .parse()
                .map_err(|_| skyloop::Error::Input(format!("{what}: '{t}' is not a number")))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(skyloop::Error::Input(format!("{what}: '{t}' is not finite")))
            }
        })
        .collect()
}
