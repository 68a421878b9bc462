//! Measured materials of Jensen, Marschner, Levoy and Hanrahan, "A Practical Model for Subsurface
//! Light Transport", SIGGRAPH 2001, Fig. 5 (the project's `materials.csv`, embedded here so nothing
//! is read at run time). sigma_s' and sigma_a in 1/mm per RGB channel; eta = 1.3 for every row.
//!
//! ```
//! let p = translucent::material::presets::find("ketchup").unwrap();
//! assert_eq!(p.sigma_a, [0.061, 0.97, 1.45]);
//! ```

/// One named preset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    pub name: &'static str,
    pub sigma_s: [f64; 3],
    pub sigma_a: [f64; 3],
    pub eta: f64,
}

const fn p(name: &'static str, sigma_s: [f64; 3], sigma_a: [f64; 3]) -> Preset {
    Preset {
        name,
        sigma_s,
        sigma_a,
        eta: 1.3,
    }
}

/// The table (Jensen et al. 2001, Fig. 5).
pub const PRESETS: [Preset; 12] = [
    p("apple", [2.29, 2.39, 1.97], [0.003, 0.0034, 0.046]),
    p("chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    p("chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.2]),
    p("cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    p("ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    p("marble", [2.19, 2.62, 3.0], [0.0021, 0.0041, 0.0071]),
    p("potato", [0.68, 0.7, 0.55], [0.0024, 0.009, 0.12]),
    p("skimmilk", [0.7, 1.22, 1.9], [0.0014, 0.0025, 0.0142]),
    p("skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    p("skin2", [1.09, 1.59, 1.79], [0.013, 0.07, 0.145]),
    p("spectralon", [11.6, 20.4, 14.9], [0.0, 0.0, 0.0]),
    p("wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
];

/// The preset of that name (case-insensitive).
pub fn find(name: &str) -> Option<&'static Preset> {
    PRESETS.iter().find(|p| p.name.eq_ignore_ascii_case(name))
}
