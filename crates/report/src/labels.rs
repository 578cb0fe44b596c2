//! Human labels with units for surae's parameter and effect names, and number formatting.

/// Label with unit of a parameter name as used in surae's JSON (`sol.lst_m`,
/// `electromechanical_delay.delay_ms`, …): `"LST sol (m)"`, `"delay (ms)"`. Unknown names
/// are returned unchanged, with a unit guessed from a `_m`, `_n`, `_deg`, `_ms`, `_s`,
/// `_nm` suffix when there is one.
///
/// ```
/// assert_eq!(report::param_label("gm.fom_n"), "F0 gm (N)");
/// assert_eq!(report::param_label("sol.alpha_deg"), "α0 sol (deg)");
/// assert_eq!(report::param_label("torque_offset.offset_nm"), "torque offset: offset (N·m)");
/// ```
pub fn param_label(name: &str) -> String {
    let (head, field) = match name.split_once('.') {
        Some((h, f)) => (Some(h), f),
        None => (None, name),
    };
    let muscle = matches!(head, Some("sol" | "gm" | "gl" | "ta"));
    if let (true, Some(m)) = (muscle, head) {
        let known = match field {
            "lst_m" => Some(("LST", "m")),
            "fom_n" => Some(("F0", "N")),
            "alpha_deg" => Some(("α0", "deg")),
            "lom_m" => Some(("LOM", "m")),
            "vmax_lom_per_s" => Some(("vmax", "LOM/s")),
            _ => None,
        };
        if let Some((sym, unit)) = known {
            return format!("{sym} {m} ({unit})");
        }
    }
    let units: [(&str, &str); 10] = [
        ("_nm_s_per_rad", "N·m·s/rad"),
        ("_kg_m2", "kg·m²"),
        ("_per_rad", "1/rad"),
        ("_per_s", "1/s"),
        ("_nm", "N·m"),
        ("_ms", "ms"),
        ("_deg", "deg"),
        ("_m", "m"),
        ("_n", "N"),
        ("_s", "s"),
    ];
    let (stem, unit) = units
        .iter()
        .find_map(|(suf, unit)| field.strip_suffix(suf).map(|s| (s, Some(*unit))))
        .unwrap_or((field, None));
    let stem = stem.replace('_', " ");
    let prefix = head
        .filter(|_| !muscle)
        .map(|h| format!("{}: ", h.replace('_', " ")))
        .or_else(|| head.map(|h| format!("{h} ")))
        .unwrap_or_default();
    match unit {
        Some(u) => format!("{prefix}{stem} ({u})"),
        None => format!("{prefix}{stem}"),
    }
}

/// `x` with `sig` significant digits in plain notation (scientific below 1e-4 or from 1e7).
///
/// ```
/// assert_eq!(report::format_sig(0.263412, 4), "0.2634");
/// assert_eq!(report::format_sig(3549.2, 4), "3549");
/// assert_eq!(report::format_sig(f64::NAN, 3), "NaN");
/// ```
pub fn format_sig(x: f64, sig: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-4..7).contains(&mag) {
        return format!("{:.*e}", sig.saturating_sub(1), x);
    }
    let dec = (sig as i32 - 1 - mag).max(0) as usize;
    format!("{x:.dec$}")
}

/// A plain-words description of an effect of the catalogue (`docs/model.md` section 5; the
/// name itself for unknown ones).
pub fn effect_description(effect: &str) -> &str {
    match effect {
        "torque_offset" => "a constant torque offset (a zeroing or gravity-compensation error)",
        "passive_joint_torque" => {
            "passive resistance of non-muscular tissue when the ankle is dorsiflexed"
        }
        "gravity" => "the uncompensated weight of the foot and attachment",
        "electromechanical_delay" => {
            "a delay between the EMG and the force it produces (electromechanical delay)"
        }
        "fatigue" => "a loss of force over the trial",
        "antagonist_coactivation" => {
            "a counter-torque from the tibialis anterior (antagonist co-activation)"
        }
        "eccentric_enhancement" => {
            "more force than expected while the muscle lengthens (eccentric enhancement)"
        }
        "viscous_damping" => "a resistance proportional to the joint speed",
        "inertia" => "the inertia of the foot and footplate during accelerations",
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels() {
        assert_eq!(param_label("sol.lst_m"), "LST sol (m)");
        assert_eq!(param_label("gl.vmax_lom_per_s"), "vmax gl (LOM/s)");
        assert_eq!(
            param_label("electromechanical_delay.delay_ms"),
            "electromechanical delay: delay (ms)"
        );
        assert_eq!(
            param_label("viscous_damping.b_nm_s_per_rad"),
            "viscous damping: b (N·m·s/rad)"
        );
        assert_eq!(param_label("curves.flen"), "curves: flen");
        assert_eq!(param_label("rms_nm"), "rms (N·m)");
        assert_eq!(param_label("sol.odd"), "sol odd");
    }

    #[test]
    fn numbers() {
        assert_eq!(format_sig(-12.3456, 3), "-12.3");
        assert_eq!(format_sig(1.0e-6, 2), "1.0e-6");
        assert_eq!(format_sig(0.0, 3), "0");
        assert_eq!(
            effect_description("fatigue"),
            "a loss of force over the trial"
        );
        assert_eq!(effect_description("x"), "x");
    }
}
