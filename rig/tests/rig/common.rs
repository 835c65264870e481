//! Cameras shared by the test files: the strongly distorted lens of the acceptance criteria and a mild
//! HD lens, both also used by `fixtures/gen_opencv_fixtures.py`.
#![allow(dead_code)]

use rig::{Distortion, PinholeCamera};

pub fn strong() -> PinholeCamera {
    PinholeCamera {
        width: 640,
        height: 480,
        fx: 536.0,
        fy: 536.0,
        cx: 320.0,
        cy: 240.0,
        distortion: Distortion { k1: -0.27, k2: -0.04, p1: 0.0018, p2: -0.0003, k3: 0.24 },
    }
}

pub fn mild() -> PinholeCamera {
    PinholeCamera {
        width: 1280,
        height: 1024,
        fx: 1400.5,
        fy: 1395.25,
        cx: 641.3,
        cy: 509.7,
        distortion: Distortion { k1: 0.08, k2: -0.15, p1: -0.0007, p2: 0.0011, k3: 0.05 },
    }
}
