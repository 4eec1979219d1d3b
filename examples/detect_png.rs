use geneva_vision::detect::{ArucoDetector, DetectorConfig, GrayView};
fn main() {
    let cfg = DetectorConfig::default();
    let det = ArucoDetector::new(&cfg).unwrap();
    for p in std::env::args().skip(1) {
        let img = geneva_vision::io::images::read_gray(std::path::Path::new(&p)).unwrap();
        let found = det
            .detect(GrayView::full(&img.data, img.width, img.height))
            .unwrap();
        println!("{p}: {:?}", found);
    }
}
