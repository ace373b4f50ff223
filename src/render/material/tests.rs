use super::*;

#[test]
fn erf_and_its_inverse_are_accurate() {
    for (x, want) in [
        (0.1f32, 0.112_462_92f64),
        (0.5, 0.520_499_9),
        (1.0, 0.842_700_8),
        (2.0, 0.995_322_3),
    ] {
        assert!((erf(x) as f64 - want).abs() < 3e-7, "erf({x}) = {}", erf(x));
        assert!((erf(-x) as f64 + want).abs() < 3e-7);
    }
    for i in -99..=99 {
        let y = i as f32 / 100.0;
        let x = erf_inv(y);
        assert!((erf(x) - y).abs() < 2e-6, "erf(erf_inv({y})) = {}", erf(x));
    }
}

/// Chi-square test of a material's sampling against its density, as
/// pbrt-v4 and Mitsuba test their BSDFs: directions binned by
/// (x, φ) with `x = (1 - cos θ)^(1/4)` (fine near the normal, where
/// narrow lobes live), observed counts against N times the density
/// integrated over each bin (midpoint rule on a finer grid, with
/// `dω = 4 x³ dx dφ`). Bins expecting fewer than 5 samples are pooled.
fn chi_square(m: &Material, wo: Vec3) -> (f64, usize, f64, f64) {
    const CT: usize = 16;
    const PH: usize = 32;
    const N: usize = 400_000;
    let mut observed = vec![0f64; CT * PH];
    let mut rng = Rng::new(7, 3);
    let bin = |w: Vec3| {
        let x = (1.0 - w.z.clamp(0.0, 1.0)).max(0.0).powf(0.25);
        let ct = ((x * CT as f32) as usize).min(CT - 1);
        let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
        let ph = ((phi / (2.0 * PI) * PH as f32) as usize).min(PH - 1);
        ct * PH + ph
    };
    let mut total = 0.0f64;
    for _ in 0..N {
        if let Some(s) = sample(m, wo, &mut rng) {
            assert!(s.wi.z > 0.0);
            let want = eval(m, wo, s.wi) * s.wi.z / s.pdf;
            assert!(
                (want - s.weight).abs().max_element() <= 1e-3 * want.max_element().max(1e-3),
                "weight {} vs f cos / pdf {}",
                s.weight,
                want
            );
            assert!(
                (pdf(m, wo, s.wi) - s.pdf).abs() <= 1e-3 * s.pdf,
                "pdf {} vs {}",
                pdf(m, wo, s.wi),
                s.pdf
            );
            observed[bin(s.wi)] += 1.0;
        }
    }
    // Expected: the density integrated over each bin.
    // Grazing narrow lobes need fine steps.
    const SUB_X: usize = 48;
    const SUB_PHI: usize = 48;
    let mut expected = vec![0f64; CT * PH];
    for ct in 0..CT {
        for ph in 0..PH {
            let mut acc = 0.0f64;
            for a in 0..SUB_X {
                for b in 0..SUB_PHI {
                    let x = (ct as f64 + (a as f64 + 0.5) / SUB_X as f64) / CT as f64;
                    let c = (1.0 - x.powi(4)) as f32;
                    let phi =
                        2.0 * PI * (ph as f32 + (b as f32 + 0.5) / SUB_PHI as f32) / PH as f32;
                    let s = (1.0 - c * c).max(0.0).sqrt();
                    let wi = Vec3::new(s * phi.cos(), s * phi.sin(), c);
                    acc += pdf(m, wo, wi) as f64 * 4.0 * x.powi(3);
                }
            }
            let area = (1.0 / CT as f64) * (2.0 * std::f64::consts::PI / PH as f64);
            let mean = acc / (SUB_X * SUB_PHI) as f64;
            expected[ct * PH + ph] = mean * area * N as f64;
            total += mean * area;
        }
    }
    let (mut chi2, mut dof) = (0.0f64, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e >= 5.0 {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    }
    let accepted = observed.iter().sum::<f64>() / N as f64;
    (chi2, dof, total, accepted)
}

#[test]
fn sampling_matches_the_density_chi_square() {
    let materials = [
        Material::lambertian(Vec3::splat(0.5)),
        Material::Microfacet {
            alpha: 0.05,
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
        },
        Material::Microfacet {
            alpha: 0.25,
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
        },
        Material::Microfacet {
            alpha: 0.7,
            eta: Vec3::splat(0.2),
            k: Vec3::splat(3.0),
        },
    ];
    for m in &materials {
        for theta in [0.0f32, 0.6, 1.2, 1.5] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let (chi2, dof, integral, accepted) = chi_square(m, wo);
            // Wilson-Hilferty: chi2/dof above 1 + 3.1 sqrt(2/dof) has
            // probability ~1e-3 under the hypothesis.
            let limit = dof as f64 * (1.0 + 3.1 * (2.0 / dof as f64).sqrt());
            assert!(
                chi2 < limit,
                "{m:?} at θ {theta}: chi² {chi2:.0} over {dof} bins (limit {limit:.0})"
            );
            // The density integrates to the share of draws that give a
            // direction (the rest reflect below the horizon): 1 for
            // Lambertian, less for rough metal seen at an angle.
            assert!(
                (integral - accepted).abs() < 5e-3,
                "{m:?} at θ {theta}: density integrates to {integral}, {accepted} of draws give a direction"
            );
            if matches!(m, Material::Lambertian { .. }) {
                assert!(
                    (integral - 1.0).abs() < 1e-3,
                    "Lambertian density integrates to {integral}"
                );
            }
        }
    }
}

#[test]
fn microfacet_sampling_matches_its_evaluation() {
    // E[weight] = integral f cos over the hemisphere, estimated both by
    // importance sampling and by uniform sampling; they must agree.
    let m = Material::Microfacet {
        alpha: 0.3,
        eta: Vec3::splat(0.2),
        k: Vec3::splat(3.0),
    };
    let wo = Vec3::new(0.4, 0.1, 0.91).normalize();
    let mut rng = Rng::new(1, 2);
    let n = 400_000;
    let mut importance = 0.0f64;
    let mut uniform = 0.0f64;
    for _ in 0..n {
        if let Some(s) = sample(&m, wo, &mut rng) {
            importance += s.weight.x as f64;
        }
        let (u, v) = rng.next_2d();
        let wi = crate::geom::sampling::uniform_hemisphere(u, v);
        uniform += (eval(&m, wo, wi).x * wi.z) as f64 * 2.0 * std::f64::consts::PI;
    }
    let (a, b) = (importance / n as f64, uniform / n as f64);
    assert!(
        (a - b).abs() < 0.02 * b.max(0.05),
        "importance {a:.4} vs uniform {b:.4}"
    );
}

#[test]
fn glass_reflectance_at_normal_incidence() {
    let f = fresnel_dielectric(1.0, 1.5);
    assert!((f - 0.04).abs() < 1e-4, "F(0) = {f}");
}
