//! `images A B`: the rotation (and translation, scale) of image B relative
//! to image A, as text or JSON.

use std::path::PathBuf;

use clap::Args;
use hough_heading_recordings::answer::{describe_images, images_result, load_images};
use hough_heading_recordings::options::{EstimatorArgs, ImageArgs};
use hough_heading_recordings::Fatal;

/// `images A B`.
#[derive(Clone, Debug, Args)]
pub struct ImagesArgs {
    /// Reference image A.
    pub a: PathBuf,
    /// Image B.
    pub b: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// How images are read.
    #[command(flatten)]
    pub image: ImageArgs,
    /// Estimator options.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
}

/// Runs `images`.
///
/// # Errors
/// Unreadable or unusable images, unusable options.
pub fn run(args: &ImagesArgs) -> Result<(), Fatal> {
    let (mut engine, offsets) = load_images(&args.a, &args.b, &args.image, &args.estimator)?;
    let r = images_result(engine.as_mut(), args.estimator.mode.into(), offsets);
    let text = if args.json {
        serde_json::to_string(&r).map_err(|e| Fatal::io(format!("JSON output: {e}")))?
    } else {
        describe_images(&r, args.estimator.mode)
    };
    println!("{text}");
    Ok(())
}
