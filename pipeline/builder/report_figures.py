"""The build report's figures: one PNG each, readable for a week and for a year, byte-identical on a rebuild.

Every figure is drawn from the episode series of :func:`pipeline.builder.validate.report_series` (name -> (B, T) arrays,
kWh per 1-h step = kW, temperatures degC, price $/kWh, carbon intensity kg CO2/kWh, ``hour`` 1..24
hour-ending, ``day_type`` 1..7 Monday..Sunday and 8 holiday). Days are the blocks that start at hour 1
(00:00-01:00); a period that starts mid-day has a short first day. Two views of time are used everywhere:
daily aggregates over the whole period (a year stays readable) and hourly values over the *peak week*, the
seven days around the day of the district's highest no-control net load.

PNGs are written by the Agg backend at :data:`DPI` with a fixed figure size in inches (:data:`SIZES`),
without the ``Software`` metadata key and with no date in the image, so two builds give the same bytes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

DPI = 100
#: figure kind -> (width, height) in inches; the PNG is width * DPI x height * DPI pixels
SIZES = {"load": (11.0, 7.0), "temperature": (11.0, 6.0), "heatmap": (11.0, 8.0), "policies": (11.0, 8.0)}
#: end use -> (series name, legend label, colour); stacked bottom to top
END_USES = (
    ("non_shiftable_load_electricity_consumption", "non-shiftable", "#9e9e9e"),
    ("dhw_electricity_consumption", "DHW", "#ff7f0e"),
    ("heating_electricity_consumption", "heating", "#d62728"),
    ("cooling_electricity_consumption", "cooling", "#1f77b4"),
)
PV_COLOUR, NET_COLOUR, CARBON_COLOUR = "#e6b800", "#000000", "#8c564b"
POLICY_COLOURS = {"no_control": "#555555", "cost_rbc": "#2ca02c"}
POLICY_LABELS = {"no_control": "no control", "cost_rbc": "cost RBC"}
INDOOR_COLOUR, SET_POINT_COLOUR, OUTDOOR_COLOUR = "#d62728", "#000000", "#7f7f7f"
WEEKDAYS = ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun", "Hol")
MONTHS = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")
#: at most this many distinct prices are drawn as tariff bands (more: price quantiles)
MAX_PRICE_BANDS = 6


# ---------------------------------------------------------------------------------------------- pure helpers
@dataclass(frozen=True)
class Calendar:
    """Day structure of an episode: ``day`` (T,) day index of each step, ``first`` (D,) first step of each
    day, ``month`` (D,) month 1..12 and ``day_type`` (D,) of each day, ``hour`` (T,) 1..24 hour-ending."""

    day: np.ndarray
    first: np.ndarray
    month: np.ndarray
    day_type: np.ndarray
    hour: np.ndarray

    @property
    def days(self) -> int:
        return int(self.first.size)


def parse_calendar(hour: np.ndarray, month: np.ndarray, day_type: np.ndarray) -> Calendar:
    """The :class:`Calendar` of (T,) ``hour`` (1..24, hour-ending), ``month`` and ``day_type`` columns."""
    hour = np.asarray(hour).astype(int)
    starts = hour == 1
    starts[0] = True
    first = np.flatnonzero(starts)
    return Calendar(day=np.cumsum(starts) - 1, first=first, month=np.asarray(month).astype(int)[first],
                    day_type=np.asarray(day_type).astype(int)[first], hour=hour)


def daily_sum(values: np.ndarray, calendar: Calendar) -> np.ndarray:
    """Sum of (..., T) ``values`` per day -> (..., D) (kWh per step -> kWh per day)."""
    rows = np.atleast_2d(values)
    out = np.stack([np.bincount(calendar.day, weights=row, minlength=calendar.days) for row in rows])
    return out if np.ndim(values) > 1 else out[0]


def daily_stat(values: np.ndarray, calendar: Calendar, stat: str) -> np.ndarray:
    """Per-day ``stat`` ("min", "max", "mean") of a (T,) series -> (D,)."""
    edges = np.append(calendar.first, values.size)
    func = {"min": np.min, "max": np.max, "mean": np.mean}[stat]
    return np.array([func(values[a:b]) for a, b in zip(edges[:-1], edges[1:], strict=True)])


def day_hour_matrix(values: np.ndarray, calendar: Calendar) -> np.ndarray:
    """A (24, D) matrix of a (T,) series: row h holds the hour starting at h:00 of each day; NaN where a short
    first or last day has no value."""
    out = np.full((24, calendar.days), np.nan)
    out[calendar.hour - 1, calendar.day] = values
    return out


def peak_week(net: np.ndarray, calendar: Calendar, days: int = 7) -> slice:
    """The steps of the ``days`` whole days around the day of the peak of (T,) ``net`` (the peak day fourth,
    shifted to stay inside the period): the hourly window of the report."""
    peak_day = int(calendar.day[int(np.argmax(net))])
    start = min(max(peak_day - days // 2, 0), max(calendar.days - days, 0))
    stop = min(start + days, calendar.days)
    end = int(calendar.first[stop]) if stop < calendar.days else net.size
    return slice(int(calendar.first[start]), end)


def price_bands(price: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Tariff level of each step of (T,) ``price`` [$ / kWh] -> (level index (T,), one label per level):
    the distinct prices when there are at most :data:`MAX_PRICE_BANDS`, else price quintiles."""
    levels = np.unique(np.round(price, 6))
    if levels.size <= MAX_PRICE_BANDS:
        return np.searchsorted(levels, np.round(price, 6)), [f"{p:.4g} $/kWh" for p in levels]
    edges = np.quantile(price, [0.2, 0.4, 0.6, 0.8])
    labels = [f"<= {edges[0]:.4g} $/kWh", *[f"{a:.4g}-{b:.4g} $/kWh" for a, b in zip(edges[:-1], edges[1:],
                                                                                 strict=True)],
              f"> {edges[-1]:.4g} $/kWh"]
    return np.searchsorted(edges, price), labels


def runs(levels: np.ndarray) -> list[tuple[int, int, int]]:
    """Runs of equal values of a (T,) integer array: (start, stop, value), stop exclusive."""
    change = np.flatnonzero(np.diff(levels)) + 1
    edges = np.concatenate(([0], change, [levels.size]))
    return [(int(a), int(b), int(levels[a])) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def safe_name(name: str) -> str:
    """A building name as a file-name part (letters, digits, ``_ . -``)."""
    return "".join(c if c.isalnum() or c in "_.-" else "_" for c in name)


# ---------------------------------------------------------------------------------------------- drawing
def _pyplot():
    import matplotlib  # matplotlib loads only when a figure is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # matplotlib loads only when a figure is drawn

    return plt


def _figure(kind: str, rows: int):
    """A figure of ``rows`` stacked axes with fixed margins [inches] (no layout engine: cheaper, and the
    same pixels whatever the labels)."""
    plt = _pyplot()
    width, height = SIZES[kind]
    fig, axes = plt.subplots(rows, 1, figsize=(width, height))
    gap = 0.85                                   # between stacked axes: x labels + the next title
    axes_height = (height - 1.1 - gap * (rows - 1)) / rows
    fig.subplots_adjust(left=0.75 / width, right=1.0 - 0.85 / width, bottom=0.75 / height, top=1.0 - 0.35 / height,
                        hspace=gap / axes_height)
    return fig, np.atleast_1d(axes)


def save(fig, path: Path) -> Path:
    """Write ``fig`` to ``path`` as a PNG at :data:`DPI` with no software/date metadata; close it."""
    fig.savefig(path, dpi=DPI, metadata={"Software": None})
    _pyplot().close(fig)
    return path


def _day_axis(ax, calendar: Calendar) -> None:
    """x axis in days of the period: month names at month starts for long periods, day numbers otherwise."""
    starts = [d for d in range(calendar.days) if d == 0 or calendar.month[d] != calendar.month[d - 1]]
    ax.set_xlim(0, calendar.days)
    if len(starts) > 2:
        ax.set_xticks(starts, [MONTHS[calendar.month[d] - 1] for d in starts], ha="left")
        ax.set_xlabel("month (days of the period)")
    else:
        months = "/".join(MONTHS[calendar.month[d] - 1] for d in starts)
        ax.set_xlabel(f"day of the period ({months})")
        ticks = ax.get_xticks()
        ticks = ticks[(ticks >= 0) & (ticks < calendar.days) & (ticks == np.round(ticks))]
        ax.set_xticks(ticks + 0.5, [str(int(t) + 1) for t in ticks])
    ax.grid(axis="y", alpha=0.3)


def _week_axis(ax, calendar: Calendar, window: slice) -> None:
    """x axis of the hourly window: one tick per day start, labelled with the weekday and the day number."""
    days = [d for d in range(calendar.days) if window.start <= calendar.first[d] < window.stop]
    ax.set_xticks([calendar.first[d] - window.start for d in days],
                  [f"{WEEKDAYS[calendar.day_type[d] - 1]}\nday {d + 1}" for d in days], ha="left")
    ax.set_xlim(0, window.stop - window.start)
    ax.set_xlabel("hour of the peak week (ticks at 00:00 local standard time)")
    ax.grid(axis="x", alpha=0.3)


def _stairs_x(n: int) -> np.ndarray:
    return np.arange(n + 1)


def _stairs(values: np.ndarray) -> np.ndarray:
    """Values for ``fill_between(step="post")`` over n + 1 edges (the last value repeated)."""
    return np.append(values, values[-1])


def _stack(ax, parts: list[tuple[np.ndarray, str, str]], pv: np.ndarray, net: np.ndarray, unit: str) -> None:
    """End uses stacked above zero, PV below zero (drawn as negative), the net as a black line; step curves."""
    x = _stairs_x(net.size)
    bottom = np.zeros(net.size)
    for values, label, colour in parts:
        top = bottom + values
        if np.any(values > 0):
            ax.fill_between(x, _stairs(bottom), _stairs(top), step="post", color=colour, label=label, lw=0)
        bottom = top
    if np.any(pv > 0):
        ax.fill_between(x, 0.0, _stairs(-pv), step="post", color=PV_COLOUR, label="PV (generation)", lw=0)
    ax.step(x, _stairs(net), where="post", color=NET_COLOUR, lw=0.9, label="net")
    ax.axhline(0.0, color="black", lw=0.5)
    ax.set_ylabel(f"electricity [{unit}]")


def _tariff_bands(ax, price: np.ndarray) -> list:
    """Shade the tariff levels of the (T,) window ``price`` behind ``ax``; return legend handles."""
    from matplotlib.patches import Patch  # matplotlib loads only when a figure is drawn

    levels, labels = price_bands(price)
    shades = _pyplot().get_cmap("Oranges")(np.linspace(0.05, 0.45, len(labels)))
    for a, b, level in runs(levels):
        ax.axvspan(a, b, color=shades[level], lw=0, zorder=0)
    used = sorted(set(levels.tolist()))
    return [Patch(color=shades[i], label=f"price {labels[i]}") for i in used]


#: fractions of the axes height where the carbon-intensity overlay runs: above the data, below the legend
CARBON_BAND = (0.66, 0.86)


def _carbon_line(ax, carbon: np.ndarray, label: str):
    """Carbon intensity [kg CO2/kWh] on a twin y axis of ``ax``, scaled into :data:`CARBON_BAND` (ticks only
    over its range); return the twin."""
    from matplotlib.ticker import MaxNLocator  # matplotlib loads only when a figure is drawn

    twin = ax.twinx()
    twin.step(_stairs_x(carbon.size), _stairs(carbon), where="post", color=CARBON_COLOUR, lw=1.0, label=label)
    twin.set_ylabel("carbon intensity [kg CO2/kWh]", color=CARBON_COLOUR)
    twin.tick_params(axis="y", colors=CARBON_COLOUR)
    lo, hi = float(np.min(carbon)), float(np.max(carbon))
    span = max(hi - lo, 0.05 * abs(hi), 1e-6)
    (a, b), centre = CARBON_BAND, (lo + hi) / 2.0
    lo, hi = centre - span / 2.0, centre + span / 2.0
    scale = span / (b - a)
    twin.set_ylim(lo - a * scale, hi + (1.0 - b) * scale)
    twin.set_yticks([t for t in MaxNLocator(3).tick_values(lo, hi) if lo - 1e-9 <= t <= hi + 1e-9])
    return twin


def _legend(ax, extra: list, columns: int = 6, on=None) -> None:
    """One legend of ``ax``'s artists, ``extra`` handles and those of ``on`` (a twin axis, drawn above)."""
    handles, _ = ax.get_legend_handles_labels()
    handles += extra + (on.get_legend_handles_labels()[0] if on is not None else [])
    (on or ax).legend(handles=handles, loc="upper left", ncols=columns, fontsize=8, framealpha=0.9)


def load_figure(path: Path, name: str, b: int, series: Mapping[str, np.ndarray], calendar: Calendar,
                window: slice) -> Path:
    """(a) Building ``b``'s electricity by end use under no control: daily totals [kWh/day] over the period
    and hourly [kWh] over the peak week, with the tariff levels shaded and the carbon intensity overlaid."""
    fig, (top, bottom) = _figure("load", 2)
    pv = -series["solar_generation"][b]
    parts = [(series[key][b], label, colour) for key, label, colour in END_USES]
    _stack(top, [(daily_sum(v, calendar), label, c) for v, label, c in parts], daily_sum(pv, calendar),
           daily_sum(series["net_electricity_consumption"][b], calendar), "kWh/day")
    twin = _carbon_line(top, daily_stat(series["carbon_intensity"][b], calendar, "mean"),
                        "carbon intensity (daily mean)")
    _day_axis(top, calendar)
    _legend(top, [], columns=7, on=twin)
    top.set_title(f"{name}: electricity by end use, no control (daily totals)")
    w = window
    _stack(bottom, [(v[w], label, c) for v, label, c in parts], pv[w], series["net_electricity_consumption"][b][w],
           "kWh per hour")
    bands = _tariff_bands(bottom, series["electricity_pricing"][b][w])
    twin = _carbon_line(bottom, series["carbon_intensity"][b][w], "carbon intensity")
    _week_axis(bottom, calendar, w)
    _legend(bottom, bands, columns=5, on=twin)
    bottom.set_title(f"{name}: hourly over the peak week, tariff periods shaded")
    _headroom(top, 0.55), _headroom(bottom, 0.55)
    return save(fig, path)


def _headroom(ax, fraction: float = 0.45) -> None:
    """Extend the y axis upwards by ``fraction`` of its span so the legend does not cover the data."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + fraction * (hi - lo))


def temperature_figure(path: Path, name: str, b: int, series: Mapping[str, np.ndarray], calendar: Calendar,
                       window: slice) -> Path:
    """(b) Building ``b``'s indoor temperature vs its set point under no control [degC]: daily range and
    means over the period, hourly over the peak week; the outdoor temperature for context."""
    fig, (top, bottom) = _figure("temperature", 2)
    indoor = series["indoor_dry_bulb_temperature"][b]
    set_point = series["indoor_dry_bulb_temperature_set_point"][b]
    outdoor = series["outdoor_dry_bulb_temperature"][b]
    x = np.arange(calendar.days) + 0.5
    top.fill_between(x, daily_stat(indoor, calendar, "min"), daily_stat(indoor, calendar, "max"),
                     color=INDOOR_COLOUR, alpha=0.25, lw=0, label="indoor, daily min-max")
    top.plot(x, daily_stat(indoor, calendar, "mean"), color=INDOOR_COLOUR, lw=1.2, label="indoor, daily mean")
    top.plot(x, daily_stat(set_point, calendar, "mean"), color=SET_POINT_COLOUR, lw=1.0, ls="--",
             label="set point, daily mean")
    top.plot(x, daily_stat(outdoor, calendar, "mean"), color=OUTDOOR_COLOUR, lw=0.9, label="outdoor, daily mean")
    _day_axis(top, calendar)
    top.set_ylabel("temperature [degC]")
    mean_gap = float(np.mean(np.abs(indoor - set_point)))
    top.set_title(f"{name}: indoor temperature vs set point, no control (mean |indoor - set point| "
                  f"{mean_gap:.2f} degC)")
    w = window
    hours = _stairs_x(w.stop - w.start)
    bottom.step(hours, _stairs(indoor[w]), where="post", color=INDOOR_COLOUR, lw=1.2, label="indoor")
    bottom.step(hours, _stairs(set_point[w]), where="post", color=SET_POINT_COLOUR, lw=1.0, ls="--",
                label="set point")
    bottom.step(hours, _stairs(outdoor[w]), where="post", color=OUTDOOR_COLOUR, lw=0.9, label="outdoor")
    bottom.set_ylabel("temperature [degC]")
    _week_axis(bottom, calendar, w)
    bottom.set_title(f"{name}: hourly over the peak week")
    for ax in (top, bottom):
        _headroom(ax, 0.3)
        ax.legend(loc="upper left", ncols=4, fontsize=8, framealpha=0.85)
    return save(fig, path)


def heatmap_figure(path: Path, nets: Mapping[str, np.ndarray], calendar: Calendar) -> Path:
    """(c) District net load [kWh per hour] as day x hour heat maps for each policy (one colour scale) and,
    for two policies, their difference (second minus first, a diverging scale centred on 0)."""
    labels = [POLICY_LABELS.get(p, p) for p in nets]
    matrices = [day_hour_matrix(net, calendar) for net in nets.values()]
    lo = min(float(np.nanmin(m)) for m in matrices)
    hi = max(float(np.nanmax(m)) for m in matrices)
    panels = [(f"district net load, {label}", m, "viridis", lo, hi) for label, m in zip(labels, matrices, strict=True)]
    if len(matrices) == 2:
        diff = matrices[1] - matrices[0]
        span = max(float(np.nanmax(np.abs(diff))), 1e-6)
        panels.append((f"{labels[1]} minus {labels[0]}: orange = more drawn from the grid (storage charging), "
                       "purple = less (discharging)", diff, "PuOr_r", -span, span))
    fig, axes = _figure("heatmap", len(panels))
    for ax, (title, matrix, cmap, vmin, vmax) in zip(axes, panels, strict=True):
        image = ax.imshow(matrix, aspect="auto", extent=(0, calendar.days, 24, 0), interpolation="nearest",
                          cmap=cmap, vmin=vmin, vmax=vmax)
        fig.colorbar(image, ax=ax, label="kWh per hour", pad=0.01, fraction=0.04)
        ax.set_yticks([0, 6, 12, 18, 24])
        ax.set_ylabel("hour of day")
        ax.set_title(title)
        _day_axis(ax, calendar)
        ax.grid(False)
    return save(fig, path)


def policies_figure(path: Path, nets: Mapping[str, np.ndarray], prices: np.ndarray, calendar: Calendar,
                    window: slice) -> Path:
    """(d) District net load under each policy: daily energy [kWh/day] and daily peak [kW] over the period,
    hourly [kWh] over the peak week with the tariff levels shaded."""
    fig, (energy, peak, hourly) = _figure("policies", 3)
    x = np.arange(calendar.days + 1)
    totals: dict[str, list[float]] = {}
    for i, (policy, net) in enumerate(nets.items()):
        colour, label = POLICY_COLOURS.get(policy), POLICY_LABELS.get(policy, policy)
        daily, peaks = daily_sum(net, calendar), daily_stat(net, calendar, "max")
        totals[label] = [float(daily.sum()), float(peaks.mean())]
        width = 2.4 if i == 0 else 1.0                               # the first wide underneath: both visible
        energy.step(x, _stairs(daily), where="post", color=colour, lw=width, label=label)
        peak.step(x, _stairs(peaks), where="post", color=colour, lw=width, label=label)
    (first, (e0, p0)), *others = totals.items()
    changes = "; ".join(f"{name}: {100 * (e - e0) / abs(e0):+.1f} %" for name, (e, _) in others) if e0 else ""
    energy.set_ylabel("net energy [kWh/day]")
    energy.set_title(f"district net energy per day ({first}: {e0:,.0f} kWh over the period; {changes})")
    changes = "; ".join(f"{name}: {100 * (p - p0) / abs(p0):+.1f} %" for name, (_, p) in others) if p0 else ""
    peak.set_ylabel("daily peak [kW]")
    peak.set_title(f"daily peak of the hourly district net load (mean {first}: {p0:.1f} kW; {changes})")
    w = window
    bands = _tariff_bands(hourly, prices[w])
    hours = _stairs_x(w.stop - w.start)
    for policy, net in nets.items():
        hourly.step(hours, _stairs(net[w]), where="post", color=POLICY_COLOURS.get(policy), lw=1.1,
                    label=POLICY_LABELS.get(policy, policy))
    hourly.set_ylabel("net [kWh per hour]")
    hourly.set_title("hourly over the peak week, tariff periods shaded")
    _week_axis(hourly, calendar, w)
    for ax in (energy, peak):
        _day_axis(ax, calendar)
        _headroom(ax, 0.3)
        ax.legend(loc="upper left", ncols=2, fontsize=8, framealpha=0.85)
    for ax in (energy, peak, hourly):
        ax.axhline(0.0, color="black", lw=0.5)
    _headroom(hourly, 0.35)
    _legend(hourly, bands, columns=5)
    return save(fig, path)
