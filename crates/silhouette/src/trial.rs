//! Which classifier suits a rig: every kind tried on one frame, and a suggestion where the
//! rig's own gives an implausible silhouette and another would not (`flexshape silhouettes`).

use image::RgbImage;

use crate::{
    BackgroundModel, Classifier, Silhouette, SilhouetteError, SilhouetteSettings, SilhouetteStatus,
    Silhouetter,
};

/// One classifier tried on a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassifierTrial {
    /// Its `kind` in the rig file (`colour_shadow`, `green_matte`, `difference`).
    pub kind: &'static str,
    /// Share of the image it takes for the object.
    pub share: f64,
    /// Object components it keeps.
    pub components: usize,
    /// Something, in one component, well under the foreground limit (a fifth of it).
    pub plausible: bool,
}

/// Every classifier kind (with its default thresholds) tried on `frame` against
/// `background`, the rest of `settings` kept.
pub fn try_classifiers(
    background: &BackgroundModel,
    frame: &RgbImage,
    settings: &SilhouetteSettings,
) -> Result<Vec<ClassifierTrial>, SilhouetteError> {
    let kinds = [
        ("colour_shadow", Classifier::colour_shadow()),
        ("green_matte", Classifier::green_matte()),
        ("difference", Classifier::Difference(Default::default())),
    ];
    let pixels = (frame.width() * frame.height()) as f64;
    kinds
        .into_iter()
        .map(|(kind, classifier)| {
            let trial = SilhouetteSettings {
                classifier,
                ..settings.clone()
            };
            let s = Silhouetter::new(background, trial)?.process(frame)?;
            let share = s.object.count() as f64 / pixels;
            Ok(ClassifierTrial {
                kind,
                share,
                components: s.components,
                plausible: s.components == 1
                    && share > 0.0
                    && share < settings.max_foreground / 5.0,
            })
        })
        .collect()
}

/// The classifier to try instead of the rig's when its silhouette `own` of a frame of
/// `pixels` pixels looks wrong (no object, implausible, several components, or a fifth of
/// the foreground limit or more) and a trial's is plausible: the one taking the least.
pub fn suggest_classifier(
    own: &Silhouette,
    pixels: u64,
    settings: &SilhouetteSettings,
    trials: &[ClassifierTrial],
) -> Option<&'static str> {
    let share = own.object.count() as f64 / pixels.max(1) as f64;
    let implausible = matches!(
        own.status,
        SilhouetteStatus::Implausible { .. } | SilhouetteStatus::NoObject
    ) || own.components > 1
        || share >= settings.max_foreground / 5.0;
    if !implausible {
        return None;
    }
    trials
        .iter()
        .filter(|t| t.plausible)
        .min_by(|a, b| a.share.total_cmp(&b.share))
        .map(|t| t.kind)
}

#[cfg(test)]
mod tests {
    use image::Rgb;

    use super::*;

    /// A grey, slightly textured backdrop, and a frame of it with the lamp dimmed to 70 % and
    /// a red bar on it.
    fn scene() -> (BackgroundModel, RgbImage) {
        let grey = |x: u32, y: u32| 190 + ((x * 7 + y * 13) % 9) as u8;
        let backdrop = RgbImage::from_fn(128, 96, |x, y| {
            let v = grey(x, y);
            Rgb([v, v, v])
        });
        let frame = RgbImage::from_fn(128, 96, |x, y| {
            if (50..62).contains(&x) && (20..80).contains(&y) {
                Rgb([150, 40, 30])
            } else {
                let v = (f64::from(grey(x, y)) * 0.7).round() as u8;
                Rgb([v, v, v])
            }
        });
        let model = BackgroundModel::from_frames(std::slice::from_ref(&backdrop)).unwrap();
        (model, frame)
    }

    #[test]
    fn a_classifier_that_takes_the_backdrop_gets_a_plausible_one_suggested() {
        let (background, frame) = scene();
        let pixels = u64::from(frame.width() * frame.height());
        // A plain difference takes the whole dimmed backdrop for the object.
        let difference = SilhouetteSettings {
            classifier: Classifier::Difference(Default::default()),
            ..SilhouetteSettings::default()
        };
        let own = Silhouetter::new(&background, difference.clone())
            .unwrap()
            .process(&frame)
            .unwrap();
        let trials = try_classifiers(&background, &frame, &difference).unwrap();
        assert_eq!(trials.len(), 3);
        let by_kind = |kind: &str| trials.iter().find(|t| t.kind == kind).unwrap();
        assert!(!by_kind("difference").plausible, "{trials:?}");
        // Colour with shadow rejection sees the dimming as shade: the bar alone.
        let colour = by_kind("colour_shadow");
        let bar = (12.0 * 60.0) / pixels as f64;
        assert!(
            colour.plausible && (colour.share / bar - 1.0).abs() < 0.1,
            "{colour:?}"
        );
        let suggested = suggest_classifier(&own, pixels, &difference, &trials);
        let best = trials
            .iter()
            .filter(|t| t.plausible)
            .min_by(|a, b| a.share.total_cmp(&b.share))
            .map(|t| t.kind);
        assert!(
            suggested.is_some() && suggested == best,
            "{suggested:?} {trials:?}"
        );
        // The rig's own classifier right: nothing to suggest.
        let right = SilhouetteSettings::default();
        let own = Silhouetter::new(&background, right.clone())
            .unwrap()
            .process(&frame)
            .unwrap();
        let trials = try_classifiers(&background, &frame, &right).unwrap();
        assert_eq!(suggest_classifier(&own, pixels, &right, &trials), None);
    }
}
