"""Result in a notebook: an HTML table (_repr_html_) with every text escaped, and a
one-line __repr__."""

import re

from conftest import hand_made_result

from granular_chain import Status


def test_html_summary_lists_the_run_and_escapes_text():
    r = hand_made_result()
    r.message = "reached t_end <b>&</b> 'quoted'"
    r.info = {"scene_name": "a<chain>&b", "warnings": ["granules 1 & 3 <overlap>"]}
    r.event_counts = {"stop": 2, "slip": 0}
    page = r._repr_html_()
    assert page.startswith("<table>") and page.endswith("</table>")
    cells = dict(re.findall(r"<tr><th[^>]*>(.*?)</th><td[^>]*>(.*?)</td></tr>", page))
    assert cells["status"] == "t_end (0)" and cells["success"] == "yes"
    assert cells["message"] == "reached t_end &lt;b&gt;&amp;&lt;/b&gt; &#x27;quoted&#x27;"
    assert cells["scene"] == "a&lt;chain&gt;&amp;b"
    assert cells["warning"] == "granules 1 &amp; 3 &lt;overlap&gt;"
    assert cells["t_final"] == "1" and cells["granules (N)"] == "6"
    assert cells["steps"] == "40" and cells["frames"] == "40"
    assert cells["events"] == "0 (stop 2)"
    led = r.energy
    assert float(cells["energy: initial"]) == float(f"{led.initial:.6g}")
    assert float(cells["energy: kinetic"]) == float(f"{led.kinetic[-1]:.6g}")
    assert float(cells["energy balance error (relative)"]) == float(f"{led.balance_error:.3g}")
    assert cells["wall time"] == "0.01 s"
    assert "<b>" not in page.replace("<b>Result</b>", "")  # no markup from the run's text


def test_html_summary_of_a_failed_event_run():
    r = hand_made_result()
    r.status, r.stepper, r.dt = Status.ZENO, "event", None
    r.message = "events accumulate"
    cells = dict(re.findall(r"<tr><th[^>]*>(.*?)</th><td[^>]*>(.*?)</td></tr>",
                            r._repr_html_()))
    assert cells["success"] == "no" and cells["status"] == "zeno (-4)"
    assert cells["mode segments"] == "40" and cells["stepper"] == "event"
    assert "#cf222e" in r._repr_html_()  # the caption in red


def test_repr_is_one_line():
    text = repr(hand_made_result())
    assert "\n" not in text and text.startswith("Result(N=6, frames=40, steps=40")
