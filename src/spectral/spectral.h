// Host-side spectral utilities (docs/method.md, "Spectra, output"): binning of piecewise-linear
// spectra into the renderer's 16 fixed bins over 400-700 nm, the bins -> linear sRGB matrix the
// film applies, and the conversions between spectral and RGB parameters. See docs/spectral.md.
#pragma once

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace cb {

constexpr int kSpectralBins = 16;
constexpr float kLambdaMin = 400.f, kLambdaMax = 700.f;
constexpr float kBinWidth = (kLambdaMax - kLambdaMin) / kSpectralBins; // 18.75 nm

// Bin i covers [binLambdaLow(i), binLambdaHigh(i)].
constexpr float binLambdaLow(int i) {
    return kLambdaMin + kBinWidth * static_cast<float>(i);
}
constexpr float binLambdaHigh(int i) {
    return kLambdaMin + kBinWidth * static_cast<float>(i + 1);
}

// (wavelength in nm, value) pairs with strictly increasing wavelengths. Between samples the
// spectrum is linear; outside [first, last] it is zero (pbrt-v4's PiecewiseLinearSpectrum).
using PiecewiseLinear = std::vector<std::pair<float, float>>;

// Value of s at nm. An empty spectrum is zero everywhere.
double evalPiecewiseLinear(const PiecewiseLinear& s, double nm);

// Exact integral of s over [a, b] (a <= b), nm * value units.
double integratePiecewiseLinear(const PiecewiseLinear& s, double a, double b);

// pbrt-v4's BlackbodySpectrum: Planck's law at `kelvin` (> 0) normalised to 1 at its peak
// (Wien's displacement law), sampled every nanometre over 360-830 nm.
PiecewiseLinear blackbody(double kelvin);

// Exact mean of s over each 18.75 nm bin. Throws std::invalid_argument if the wavelengths are
// not strictly increasing or a value is not finite.
std::array<float, kSpectralBins> binSpectrum(const PiecewiseLinear& s);

// CIE 1931 2-degree colour matching functions (x, y, z) at nm, from the multi-lobe
// piecewise-Gaussian fit of Wyman, Sloan & Shirley 2013, JCGT 2(2), listing 1.
std::array<double, 3> cieXyz1931Fit(double nm);

// CIE XYZ of s over the model's range 400-700 nm (fine quadrature, not binned), normalised like
// the 16-bin pipeline: a flat spectrum of value 1 has Y = 1. Light outside 400-700 nm is
// ignored, as in the renderer. For reference and tests.
std::array<double, 3> spectrumToXyz(const PiecewiseLinear& s);

// 3 x channels row-major matrix M with linearSRGB = M * channels.
// channels == 3: identity. channels == 16: per-bin CMF integrals normalised to Y(flat 1) = 1,
// Bradford adaptation from the equal-energy white E to D65, then XYZ -> linear sRGB (Rec. 709
// primaries). Throws std::invalid_argument for any other channel count.
std::vector<float> channelsToRgbMatrix(int channels);

// Linear sRGB of the binned spectrum: channelsToRgbMatrix(16) * binSpectrum(s). Used to render a
// spectral parameter in an RGB scene consistently with the 16-bin pipeline.
std::array<float, 3> spectrumToRgb(const PiecewiseLinear& s);

// Linear sRGB of 16 bin values (channelsToRgbMatrix(16) applied).
std::array<float, 3> binsToRgb(const std::array<float, kSpectralBins>& bins);

// 16-bin spectrum for an RGB parameter in a spectral scene, after Smits 1999 ("An RGB-to-spectrum
// conversion for reflectances"): white + one secondary + one primary basis spectrum, each fit so
// that, lit by the white of RGB lights (whiteIlluminantBins), it renders through the film as its
// target, as pbrt-v4's albedo spectra do under D65. (1,1,1) maps to the flat spectrum 1 exactly;
// rgb in [0,1]^3 gives bins in [0,1] and renders as rgb under that white; the map is positively
// homogeneous, so emission (rgb > 1) scales linearly.
std::array<float, kSpectralBins> rgbToSpectrum(std::array<float, 3> rgb);

// The seven basis spectra used by rgbToSpectrum, in the order white, cyan, magenta, yellow, red,
// green, blue (exposed for tests and docs).
const std::array<std::array<float, kSpectralBins>, 7>& smitsBasis();

// pbrt-v4's SpectrumToPhotometric for a spectrum given inline: the integral of s times y-bar over
// pbrt's 360-830 nm (nm * value units; a flat spectrum of 1 gives about 106.9). pbrt-v4 divides
// every light's L or I spectrum by it, so that the light's luminance is its "scale".
double photometricIntegral(const PiecewiseLinear& s);

// Colour settings of pbrt-v4's "rgb" film: its "cie1931" sensor or a camera's.
struct FilmColour {
    double whiteBalanceKelvin = 0.0; // "whitebalance": 0 = none (the cie1931 default)
    double imagingRatio = 1.0;       // exposure time * "iso" / 100
    // A camera of camera_sensors.h ("canon_eos_100d"), or empty for the CIE 1931 observer.
    // A camera's white balance is its sensor illuminant, 6500 K when whiteBalanceKelvin is 0.
    std::string sensor;
};

// pbrt-v4's XYZFromSensorRGB for a camera (film.h, PixelSensor), row-major: the linear least
// squares fit of the 24 ColorChecker patches' XYZ under the colour space's D65 (times the
// sensor illuminant's Y over its G) from their camera RGB under the sensor illuminant, the CIE
// daylight of `kelvin` (Planck's law below a correlated 4000 K, as pbrt-v4's Spectra::D); each
// camera RGB and XYZ divided by the illuminant's G or Y (pbrt-v4's ProjectReflectance), sums
// over pbrt-v4's 1 nm steps from 360 to 830 nm. Throws std::invalid_argument for an unknown
// camera.
std::array<double, 9> xyzFromCameraRgb(const std::string& camera, double kelvin);

// 3 x channels row-major matrix M with linear sRGB = M * channels, as pbrt-v4's RGB film
// computes pixel values (film.h, PixelSensor::ToSensorRGB, RGBFilm): XYZ = integral of L times the
// CMFs (absolute, no normalisation; for 16 channels each bin weighted by the CMF integral over
// it), then the Bradford white balance from the CIE daylight illuminant of whiteBalanceKelvin
// (Planckian below 4000 K) to D65 when given, then XYZ -> linear sRGB, times imagingRatio. For
// 3 channels (RGB scenes) the same white balance and ratio act on linear sRGB. With a camera
// sensor, camera RGB = the integral of L times its sensitivities (each bin weighted by their
// integral over it), then XYZ by xyzFromCameraRgb, linear sRGB, times imagingRatio; a camera
// needs the 16 channels (std::invalid_argument for 3).
std::vector<float> filmMatrix(int channels, const FilmColour& film);

// 3 x 3 row-major matrix from the film's linear sRGB (filmMatrix's output) to pbrt-v4's sensor
// RGB, on which its film clamps samples ("maxcomponentvalue"): for the cie1931 sensor, XYZ
// before the white balance, times the imaging ratio; for a camera, its RGB times the ratio.
std::array<float, 9> sensorFromFilmRgb(const FilmColour& film);

// Film-space linear sRGB (no white balance) of an emission spectrum, binned as the renderer
// does: the RGB-channel rendering of a spectral light, consistent with filmMatrix(16, {}).
std::array<float, 3> emissionToRgb(const PiecewiseLinear& s);

// 16 bins for an RGB emission value in a spectral scene. pbrt-v4 emits RGB as the RGB's smooth
// spectrum times the colour space's illuminant (D65) normalised to luminance 1; cbdpt carries no
// D65 table, so it multiplies rgbToSpectrum(rgb) by the smoothest quadratic-in-wavelength
// spectrum whose film colour is D65's white at luminance 1: (1,1,1) renders as (1,1,1), as in
// pbrt-v4.
std::array<float, kSpectralBins> rgbIlluminantSpectrum(std::array<float, 3> rgb);

// The illuminant used by rgbIlluminantSpectrum (rgb (1,1,1)).
const std::array<float, kSpectralBins>& whiteIlluminantBins();

// CIE 1931 xy chromaticity of the white a "whitebalance" temperature stands for, as pbrt-v4's
// Spectra::D: the daylight locus from 4000 K (correlated colour temperature T * 1.4388 / 1.4380),
// a Planckian radiator below.
std::array<double, 2> whiteBalanceChromaticity(double kelvin);

} // namespace cb
