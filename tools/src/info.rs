//! `translucent info [--json]`: the Vulkan device, driver, API version, the features we use,
//! whether validation is on and whether GPU timestamps work.

use translucent::vk::{Context, ContextDesc};

#[derive(clap::Args)]
pub struct InfoArgs {
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    let info = ctx.info().clone();
    let messages = ctx.take_validation_messages();
    drop(ctx);
    if args.json {
        let mut value = serde_json::to_value(&info)?;
        value["validation_messages"] = serde_json::json!(messages.len());
        println!("{value}");
    } else {
        println!("device:      {} ({})", info.device_name, info.device_type);
        println!("driver:      {} {}", info.driver_name, info.driver_info);
        println!("api version: {}", info.api_version);
        println!("features:    {}", info.features.join(", "));
        println!(
            "validation:  {}",
            if info.validation {
                "on"
            } else {
                "off (TRANSLUCENT_VALIDATION=1 turns it on)"
            }
        );
        println!(
            "timestamps:  {}",
            if info.timestamps {
                format!("yes ({} ns per tick)", info.timestamp_period_ns)
            } else {
                "no (profiler off)".into()
            }
        );
        println!("subgroup:    {}", info.subgroup_size);
    }
    if !messages.is_empty() {
        anyhow::bail!("{} validation message(s) (printed above)", messages.len());
    }
    Ok(())
}
