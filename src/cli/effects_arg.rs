//! The `--effects a,b,c` list of `geneva diagnose` (candidates) and `geneva diagnose-selfcheck`
//! (withheld effects): names of the effect vocabulary, checked against [`Effect::from_name`].

use anyhow::{Context, Result};
use geneva_vision::scenario::effects::Effect;

/// The named effects, or `None` when the option was not given; an unknown name is an error
/// that lists the vocabulary.
pub fn parse_effects(names: Option<&[String]>) -> Result<Option<Vec<Effect>>> {
    let Some(names) = names else {
        return Ok(None);
    };
    names
        .iter()
        .map(|n| {
            Effect::from_name(n).with_context(|| {
                format!(
                    "--effects: `{n}` is not an effect; the vocabulary is: {}",
                    Effect::names()
                )
            })
        })
        .collect::<Result<Vec<Effect>>>()
        .map(Some)
}
