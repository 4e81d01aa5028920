/* sun.c — the sun's topocentric azimuth and elevation by NREL's Solar Position Algorithm
 * (Reda & Andreas, NREL/TP-560-34302, revised 2008; equation numbers are the report's), the
 * C twin of oclshade/solar/position.py sun_position, step for step, with its conventions and
 * its Delta T estimate (Espenak & Meeus 2006).  Pure host code: no OpenCL.  The two agree to
 * 1e-8 degree (a POSIX time in float64 carries up to 0.5 us of rounding, 2e-9 degree of the
 * sun's motion, and numpy's sums and trigonometry may differ from the C library's in the last
 * bits; tests/test_host_sun.py). */
#include "oclshade.h"
#include "spa_tables.h"

#include <math.h>

#define SPA_PI 3.14159265358979323846
#define J2000_UNIX 946728000.0            /* 2000-01-01T12:00Z in POSIX seconds */
#define EARTH_RADIUS_M 6378140.0          /* SPA eqs. 38-39 */
#define SUN_RADIUS_DEG 0.26667            /* the refraction cut-off: -(sun radius + refraction at the horizon) */
#define HORIZON_REFRACTION_DEG 0.5667

static double radians(double d) { return d * (SPA_PI / 180.0); }
static double degrees(double r) { return r * (180.0 / SPA_PI); }
static double mod360(double x) { return x - 360.0 * floor(x / 360.0); }   /* numpy's x % 360 */

/* sum(c_k x^k), lowest power first (numpy's polyval, Horner from the top) */
static double polynomial(double x, const double *c, int n)
{
    double s = 0.0;
    for (int k = n - 1; k >= 0; --k) s = s * x + c[k];
    return s;
}

/* SPA eqs. 9-11: sum_i JME^i sum(a cos(b + c JME)) over the tables of one letter, / 1e8 */
static double series(const spa_term *const *tables, const int *counts, int powers, double jme)
{
    double total = 0.0;
    for (int p = powers - 1; p >= 0; --p) {
        double term = 0.0;
        for (int i = 0; i < counts[p]; ++i) term += tables[p][i].a * cos(tables[p][i].b + tables[p][i].c * jme);
        total = total * jme + term;
    }
    return total / 1e8;
}

double oclshade_delta_t_estimate(double year)
{
    static const double c1900[] = {-2.79, 1.494119, -0.0598939, 0.0061966, -0.000197};
    static const double c1920[] = {21.20, 0.84493, -0.076100, 0.0020936};
    static const double c1941[] = {29.07, 0.407, -1.0 / 233.0, 1.0 / 2547.0};
    static const double c1961[] = {45.45, 1.067, -1.0 / 260.0, -1.0 / 718.0};
    static const double c1986[] = {63.86, 0.3345, -0.060374, 0.0017275, 0.000651814, 0.00002373599};
    static const double c2005[] = {62.92, 0.32217, 0.005589};
    const double u = (year - 1820.0) / 100.0;
    if (year < 1900.0) return -20.0 + 32.0 * u * u;
    if (year < 1920.0) return polynomial(year - 1900.0, c1900, 5);
    if (year < 1941.0) return polynomial(year - 1920.0, c1920, 4);
    if (year < 1961.0) return polynomial(year - 1950.0, c1941, 4);
    if (year < 1986.0) return polynomial(year - 1975.0, c1961, 4);
    if (year < 2005.0) return polynomial(year - 2000.0, c1986, 6);
    if (year < 2050.0) return polynomial(year - 2000.0, c2005, 3);
    if (year < 2150.0) return -20.0 + 32.0 * u * u - 0.5628 * (2150.0 - year);
    return -20.0 + 32.0 * u * u;
}

void oclshade_sun_options_init(oclshade_sun_options *options)
{
    options->altitude = 0.0;
    options->pressure = 1010.0;
    options->temperature = 10.0;
    options->delta_t = NAN;
    options->refraction = 1;
}

/* X0..X4 (degrees) as cubic polynomials of JCE (eqs. 15-19), the mean obliquity in arcseconds (eq. 24) */
static const double NUTATION_ARGUMENTS[5][4] = {
    {297.85036, 445267.111480, -0.0019142, 1.0 / 189474.0},
    {357.52772, 35999.050340, -0.0001603, -1.0 / 300000.0},
    {134.96298, 477198.867398, 0.0086972, 1.0 / 56250.0},
    {93.27191, 483202.017538, -0.0036825, 1.0 / 327270.0},
    {125.04452, -1934.136261, 0.0020708, 1.0 / 450000.0},
};
static const double OBLIQUITY_ARCSEC[11] = {84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12,
                                            27.87, 5.79, 2.45};

oclshade_status oclshade_sun_position(double unix_seconds, double latitude, double longitude,
                                      const oclshade_sun_options *options, double *azimuth, double *elevation)
{
    oclshade_sun_options o;
    if (options) o = *options;
    else oclshade_sun_options_init(&o);
    if (!azimuth || !elevation || !isfinite(unix_seconds) || !(latitude >= -90.0 && latitude <= 90.0) ||
        !(longitude >= -180.0 && longitude <= 180.0) || !isfinite(o.altitude) || !(o.pressure > 0.0) ||
        !isfinite(o.pressure) || !(o.temperature > -273.0) || !isfinite(o.temperature) || isinf(o.delta_t) ||
        (o.refraction != 0 && o.refraction != 1))
        return OCLSHADE_INVALID_ARGUMENT;
    const double seconds = unix_seconds - J2000_UNIX;
    const double dt = isnan(o.delta_t) ? oclshade_delta_t_estimate(2000.0 + seconds / (365.25 * 86400.0)) : o.delta_t;
    const double jd = seconds / 86400.0;                       /* JD - 2451545 (UT), eq. 4 */
    const double jc = jd / 36525.0;                            /* eq. 5 */
    const double jce = (jd + dt / 86400.0) / 36525.0;          /* eqs. 5-7 (TT) */
    const double jme = jce / 10.0;

    /* Earth's heliocentric position (eqs. 9-14) and the sun's geocentric one (eqs. 13-14) */
    const double big_l = mod360(degrees(series(SPA_L, SPA_L_COUNT, SPA_L_POWERS, jme)));
    const double big_b = degrees(series(SPA_B, SPA_B_COUNT, SPA_B_POWERS, jme));
    const double big_r = series(SPA_R, SPA_R_COUNT, SPA_R_POWERS, jme);
    const double theta = mod360(big_l + 180.0), beta = -big_b;

    /* nutation (eqs. 15-23) and the true obliquity of the ecliptic (eqs. 24-25) */
    double x[5];
    for (int k = 0; k < 5; ++k) x[k] = polynomial(jce, NUTATION_ARGUMENTS[k], 4);
    double dpsi = 0.0, deps = 0.0;
    for (int i = 0; i < SPA_NUTATION_COUNT; ++i) {
        const double *row = SPA_NUTATION[i];
        double sum = 0.0;
        for (int k = 0; k < 5; ++k) sum += x[k] * row[k];
        const double arg = radians(sum);
        dpsi += (row[5] + row[6] * jce) * sin(arg);
        deps += (row[7] + row[8] * jce) * cos(arg);
    }
    dpsi /= 36e6;
    deps /= 36e6;
    const double eps = polynomial(jme / 10.0, OBLIQUITY_ARCSEC, 11) / 3600.0 + deps;

    /* apparent sun longitude (eqs. 26-27), sidereal time (eqs. 28-29), right ascension and declination (30-33) */
    const double lam = theta + dpsi - 20.4898 / (3600.0 * big_r);
    double nu = mod360(280.46061837 + 360.98564736629 * jd + jc * jc * (0.000387933 - jc / 38710000.0));
    nu += dpsi * cos(radians(eps));
    const double lam_r = radians(lam), eps_r = radians(eps), beta_r = radians(beta);
    const double alpha = degrees(atan2(sin(lam_r) * cos(eps_r) - tan(beta_r) * sin(eps_r), cos(lam_r)));
    const double dec_r = asin(sin(beta_r) * cos(eps_r) + cos(beta_r) * sin(eps_r) * sin(lam_r));

    /* topocentric hour angle and declination: parallax (eqs. 34-40) */
    const double h_r = radians(mod360(nu + longitude - alpha));
    const double xi_r = radians(8.794 / (3600.0 * big_r));
    const double lat_r = radians(latitude);
    const double u = atan(0.99664719 * tan(lat_r));
    const double px = cos(u) + o.altitude / EARTH_RADIUS_M * cos(lat_r);
    const double py = 0.99664719 * sin(u) + o.altitude / EARTH_RADIUS_M * sin(lat_r);
    const double denominator = cos(dec_r) - px * sin(xi_r) * cos(h_r);
    const double dalpha = atan2(-px * sin(xi_r) * sin(h_r), denominator);
    const double dec_topo_r = atan2((sin(dec_r) - py * sin(xi_r)) * cos(dalpha), denominator);
    const double h_t = h_r - dalpha;

    /* elevation (eqs. 41-43, refraction eq. 42 while the upper limb is up) and azimuth (eqs. 44-46) */
    const double e0 = degrees(asin(sin(lat_r) * sin(dec_topo_r) + cos(lat_r) * cos(dec_topo_r) * cos(h_t)));
    double e = e0;
    const double cutoff = -(SUN_RADIUS_DEG + HORIZON_REFRACTION_DEG);
    if (o.refraction && e0 >= cutoff)
        e += (o.pressure / 1010.0) * (283.0 / (273.0 + o.temperature)) * 1.02 /
             (60.0 * tan(radians(e0 + 10.3 / (e0 + 5.11))));
    const double gamma = degrees(atan2(sin(h_t), cos(h_t) * sin(lat_r) - tan(dec_topo_r) * cos(lat_r)));
    *azimuth = mod360(gamma + 180.0);
    *elevation = e;
    return OCLSHADE_OK;
}
