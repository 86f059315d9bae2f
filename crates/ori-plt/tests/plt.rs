//! GC(s0), the PLT and its lower bound, the runtime check, the artifact and `[plt]`.

use ori_plt::{AutoStep, Plt, PltParams, PltValue, auto_resolution, estimate, fits};

#[test]
fn plt_is_s0_squared_over_the_worst_error() {
    let plt = estimate(256, &[10, 0, 243, 97, 243]);
    assert_eq!(plt.gc, 243);
    assert_eq!(
        plt.worst_direction,
        Some(2),
        "the first of the worst directions"
    );
    assert_eq!(plt.value(), PltValue::Pixels(65536.0 / 243.0));
    assert_eq!(plt.to_string(), "270");
    // The paper's advice, about 2 x PLT: 539 px is nearest to 512.
    assert_eq!(plt.recommended_resolution(), 512);
    assert!(fits(&plt, 269.0) && fits(&plt, 65536.0 / 243.0) && !fits(&plt, 270.0));
}

#[test]
fn no_error_at_all_reports_a_lower_bound() {
    let plt = estimate(256, &[0; 320]);
    assert_eq!(plt.gc, 0);
    assert_eq!(plt.worst_direction, None);
    assert_eq!(plt.value(), PltValue::AtLeast(65536.0));
    assert_eq!(plt.to_string(), ">= 65536");
    // Decisions use the bound: proven up to s0^2, no further.
    assert!(fits(&plt, 65536.0) && !fits(&plt, 65537.0));
    assert_eq!(estimate(64, &[]).value(), PltValue::AtLeast(4096.0));
}

#[test]
fn the_artifact_round_trips_and_rejects_damage() {
    for plt in [estimate(256, &[5, 9]), estimate(128, &[])] {
        let bytes = plt.encode();
        assert_eq!(Plt::decode(&bytes), Ok(plt));
        assert!(Plt::decode(&bytes[..bytes.len() - 1]).is_err());
        let mut bad = bytes.clone();
        bad[0] ^= 1;
        assert!(Plt::decode(&bad).is_err());
    }
    // GC > 0 needs a worst direction and the other way round.
    let mut bytes = estimate(256, &[5]).encode();
    bytes[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(Plt::decode(&bytes).is_err());
}

#[test]
fn params_come_from_a_plt_section() {
    let p: PltParams = toml::from_str("target_px = 300").unwrap();
    assert_eq!(p.target_px, 300);
    assert_eq!(p.min_resolution, PltParams::default().min_resolution);
    assert!(p.validate().is_ok());
    assert!(toml::from_str::<PltParams>("target = 300").is_err());
    for bad in [
        "min_resolution = 100",
        "max_resolution = 16384",
        "min_resolution = 512\nmax_resolution = 256",
        "target_px = 0",
    ] {
        let p: PltParams = toml::from_str(bad).unwrap();
        assert!(p.validate().is_err(), "{bad}");
    }
}

#[test]
fn auto_mode_starts_from_the_papers_advice() {
    let params = PltParams {
        target_px: 150,
        ..PltParams::default()
    };
    // 2 x 150 = 300 -> 256.
    assert_eq!(auto_resolution(&params, &[]), AutoStep::Try(256));
    // 256 reaches it, 128 does not: 256 wins.
    let tried = [(256, estimate(256, &[300])), (128, estimate(256, &[700]))];
    assert_eq!(
        auto_resolution(&params, &tried),
        AutoStep::Done {
            resolution: 256,
            reached: true
        }
    );
    // GC = 0 counts as reaching any target up to s0^2.
    let tried = [(64, estimate(256, &[])), (32, estimate(256, &[]))];
    assert_eq!(
        auto_resolution(&params, &tried),
        AutoStep::Done {
            resolution: 32,
            reached: true
        }
    );
}
