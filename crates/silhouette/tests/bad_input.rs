//! Bad input gives typed errors; a frame without the object gives an empty mask and a status.

use flexshape_silhouette::{
    BackgroundModel, Classifier, SilhouetteError, SilhouetteSettings, SilhouetteStatus, Silhouetter,
};
use image::{DynamicImage, GrayImage, Rgb, RgbImage};

fn silhouetter(classifier: Classifier) -> (RgbImage, Silhouetter) {
    let bg = RgbImage::from_fn(64, 48, |x, y| {
        Rgb([170 + (x % 7) as u8, 215 + (y % 5) as u8, 160])
    });
    let model = BackgroundModel::from_frames(std::slice::from_ref(&bg)).unwrap();
    let s = Silhouetter::new(
        &model,
        SilhouetteSettings {
            classifier,
            ..Default::default()
        },
    )
    .unwrap();
    (bg, s)
}

#[test]
fn size_channels_and_empty_frames_are_typed_errors() {
    let (_, s) = silhouetter(Classifier::colour_shadow());
    assert!(matches!(
        s.process(&RgbImage::new(32, 48)),
        Err(SilhouetteError::SizeMismatch {
            width: 32,
            height: 48,
            expected_width: 64,
            expected_height: 48
        })
    ));
    assert!(matches!(
        s.process(&RgbImage::new(0, 0)),
        Err(SilhouetteError::EmptyFrame)
    ));
    let grey = DynamicImage::ImageLuma8(GrayImage::new(64, 48));
    let err = s.process_image(&grey).unwrap_err();
    assert!(
        matches!(
            err,
            SilhouetteError::ChannelCount {
                channels: 1,
                bits: 8
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("8-bit RGB"));
    let rgb16 = DynamicImage::ImageRgb16(image::ImageBuffer::new(64, 48));
    assert!(matches!(
        s.process_image(&rgb16),
        Err(SilhouetteError::ChannelCount {
            channels: 3,
            bits: 16
        })
    ));
    let rgba = DynamicImage::ImageRgba8(image::RgbaImage::new(64, 48));
    assert!(s.process_image(&rgba).is_ok());
}

#[test]
fn a_frame_without_the_object_is_empty_with_a_status() {
    for c in [Classifier::colour_shadow(), Classifier::green_matte()] {
        let (bg, s) = silhouetter(c);
        // The background itself, with noise, and with a few isolated dark specks.
        let mut frame = bg.clone();
        for (i, p) in frame.pixels_mut().enumerate() {
            let n = ((i * 7919) % 5) as u8;
            p.0 = [p[0].saturating_add(n), p[1].saturating_sub(n), p[2]];
        }
        frame.put_pixel(10, 10, Rgb([0, 0, 0]));
        frame.put_pixel(40, 30, Rgb([0, 0, 0]));
        let out = s.process(&frame).unwrap();
        assert_eq!(out.object.count(), 0);
        assert_eq!(out.markers.count(), 0);
        assert_eq!(out.status, SilhouetteStatus::NoObject);
        assert_eq!(out.components, 0);
    }
}

#[test]
fn an_object_without_tape_reports_no_markers() {
    let (bg, s) = silhouetter(Classifier::colour_shadow());
    let mut frame = bg;
    for y in 10..40 {
        for x in 20..30 {
            frame.put_pixel(x, y, Rgb([30, 45, 90]));
        }
    }
    let out = s.process(&frame).unwrap();
    assert_eq!(out.object.count(), 300);
    assert_eq!(out.status, SilhouetteStatus::NoMarkers);
    for x in 25..28 {
        for y in 15..20 {
            frame.put_pixel(x, y, Rgb([200, 25, 20]));
        }
    }
    let out = s.process(&frame).unwrap();
    assert_eq!(out.status, SilhouetteStatus::Ok);
    assert!(out.markers.count() >= 15);
}

#[test]
fn bad_settings_are_rejected() {
    let bg = RgbImage::from_pixel(8, 8, Rgb([200, 200, 200]));
    let model = BackgroundModel::from_frames(&[bg]).unwrap();
    let bad = SilhouetteSettings {
        classifier: Classifier::GreenMatte(flexshape_silhouette::GreenMatte {
            fraction: 1.5,
            ..Default::default()
        }),
        ..Default::default()
    };
    let err = Silhouetter::new(&model, bad).unwrap_err();
    assert!(err.to_string().contains("fraction"), "{err}");
}

#[test]
fn settings_come_from_the_rig_with_per_camera_overrides() {
    let table: toml::Table = toml::from_str(
        r#"
        [silhouette]
        classifier = { kind = "colour_shadow", dark_weak = 0.55 }
        keep = "largest"
        [silhouette.per_camera.cam2]
        classifier = { kind = "green_matte", fraction = 0.4 }
        close_radius = 2
        "#,
    )
    .unwrap();
    let cam0 = SilhouetteSettings::from_processing(&table, "cam0").unwrap();
    let Classifier::ColourShadow(c) = &cam0.classifier else {
        panic!("cam0 keeps colour_shadow")
    };
    assert_eq!((c.dark_weak, c.dark), (0.55, 0.40));
    assert_eq!(cam0.keep, flexshape_silhouette::KeepComponents::Largest);
    let cam2 = SilhouetteSettings::from_processing(&table, "cam2").unwrap();
    assert_eq!(cam2.close_radius, 2);
    assert!(
        matches!(&cam2.classifier, Classifier::GreenMatte(g) if g.fraction == 0.4 && g.min_difference == 20.0)
    );
    assert_eq!(
        SilhouetteSettings::from_processing(&toml::Table::new(), "cam0").unwrap(),
        SilhouetteSettings::default()
    );
    let typo: toml::Table = toml::from_str("[silhouette]\nclose_radiu = 2\n").unwrap();
    let err = SilhouetteSettings::from_processing(&typo, "cam0")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("close_radiu") && err.contains("processing.silhouette"),
        "{err}"
    );
    let bad: toml::Table =
        toml::from_str("[silhouette]\nclassifier = { kind = \"green_matte\", fraction = 3.0 }\n")
            .unwrap();
    assert!(
        SilhouetteSettings::from_processing(&bad, "cam0")
            .unwrap_err()
            .to_string()
            .contains("fraction")
    );
}
