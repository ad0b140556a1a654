//! The vehicle file (`config/vehicles/*.toml`) → validated [`VehicleParams`].

use super::fields::{parse_toml, read_text, Fields};
use super::ConfigError;
use crate::model::VehicleParams;
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VehicleFile {
    name: Option<String>,
    chassis: Option<Chassis>,
    wheel: Option<Wheel>,
    tire: Option<Tire>,
    load_transfer: Option<LoadTransfer>,
    limits: Option<Limits>,
    model: Option<Model>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Chassis {
    m: Option<f64>,
    #[serde(rename = "L")]
    l: Option<f64>,
    a: Option<f64>,
    b: Option<f64>,
    h_cg: Option<f64>,
    #[serde(rename = "I_z")]
    i_z: Option<f64>,
    g: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Wheel {
    #[serde(rename = "R_w")]
    r_w: Option<f64>,
    #[serde(rename = "I_w")]
    i_w: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Tire {
    #[serde(rename = "C_f")]
    c_f: Option<f64>,
    #[serde(rename = "C_r")]
    c_r: Option<f64>,
    mu: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadTransfer {
    #[serde(rename = "c_L")]
    c_l: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Limits {
    delta_max: Option<f64>,
    #[serde(rename = "T_comb_max")]
    t_comb_max: Option<f64>,
    #[serde(rename = "T_comb_min")]
    t_comb_min: Option<f64>,
    #[serde(rename = "T_bf_min")]
    t_bf_min: Option<f64>,
    #[serde(rename = "T_bf_max")]
    t_bf_max: Option<f64>,
    #[serde(rename = "V_wr_min")]
    v_wr_min: Option<f64>,
    delta_rate_max: Option<f64>,
    #[serde(rename = "T_comb_rate_max")]
    t_comb_rate_max: Option<f64>,
    #[serde(rename = "T_bf_rate_max")]
    t_bf_rate_max: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Model {
    eps_sigma: Option<f64>,
    eps_sat: Option<f64>,
    fmax_floor_frac: Option<f64>,
}

/// Reads and validates a vehicle file (schema of `config/vehicles/lc500.toml`).
pub fn load_vehicle(path: &Path) -> Result<VehicleParams, ConfigError> {
    let text = read_text(path)?;
    let raw: VehicleFile = parse_toml(path, &text)?;
    let f = Fields::new(path);

    let name = f.req(raw.name, "name")?;
    if name.trim().is_empty() {
        return Err(f.invalid("name", "\"\"", "must not be empty"));
    }
    let c = f.req(raw.chassis, "chassis")?;
    let w = f.req(raw.wheel, "wheel")?;
    let t = f.req(raw.tire, "tire")?;
    let lt = f.req(raw.load_transfer, "load_transfer")?;
    let lim = f.req(raw.limits, "limits")?;
    let md = f.req(raw.model, "model")?;

    let p = VehicleParams {
        m: f.pos(c.m, "chassis.m")?,
        l: f.pos(c.l, "chassis.L")?,
        a: f.pos(c.a, "chassis.a")?,
        b: f.pos(c.b, "chassis.b")?,
        h_cg: f.pos(c.h_cg, "chassis.h_cg")?,
        i_z: f.pos(c.i_z, "chassis.I_z")?,
        g: f.pos(c.g, "chassis.g")?,
        r_w: f.pos(w.r_w, "wheel.R_w")?,
        i_w: f.pos(w.i_w, "wheel.I_w")?,
        c_f: f.pos(t.c_f, "tire.C_f")?,
        c_r: f.pos(t.c_r, "tire.C_r")?,
        mu: f.pos(t.mu, "tire.mu")?,
        c_l: f.pos(lt.c_l, "load_transfer.c_L")?,
        delta_max: f.pos(lim.delta_max, "limits.delta_max")?,
        t_comb_max: f.num(lim.t_comb_max, "limits.T_comb_max")?,
        t_comb_min: f.num(lim.t_comb_min, "limits.T_comb_min")?,
        t_bf_min: f.num(lim.t_bf_min, "limits.T_bf_min")?,
        t_bf_max: f.num(lim.t_bf_max, "limits.T_bf_max")?,
        v_wr_min: f.num(lim.v_wr_min, "limits.V_wr_min")?,
        delta_rate_max: f.pos(lim.delta_rate_max, "limits.delta_rate_max")?,
        t_comb_rate_max: f.pos(lim.t_comb_rate_max, "limits.T_comb_rate_max")?,
        t_bf_rate_max: f.pos(lim.t_bf_rate_max, "limits.T_bf_rate_max")?,
        eps_sigma: f.pos(md.eps_sigma, "model.eps_sigma")?,
        eps_sat: f.pos(md.eps_sat, "model.eps_sat")?,
        fmax_floor_frac: f.pos(md.fmax_floor_frac, "model.fmax_floor_frac")?,
    };

    // The consistency checks (a + b = L, torque limits ordered, ...) and the physical
    // ranges are the model's own.
    p.check()
        .map_err(|e| f.invalid(e.field, e.value, e.expected))?;
    p.check_ranges()
        .map_err(|e| f.invalid(e.field, format!("{:?}", e.value), e.expected))?;
    Ok(p)
}
