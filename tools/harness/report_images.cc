// The report's images (docs/report.md, "Images"): per item (the first of each scene and level) a
// strip of tiles, clean, degraded and each method, linking the images the sweep saved (relative
// links: the page and the sweep folder work from file://, nothing is fetched from a network).
// Clicking a tile opens the viewer: the method's image at full size next to the clean image and
// the degraded input, or over one of them with a slider; the page's one script does it.
#include <set>

#include "tools/harness/report_internal.h"

namespace turbid::report {
namespace {

// One tile: a link to the image (also without script) around its lazily loaded thumbnail.
std::string Tile(const ReportData& d, const std::string& path, const std::string& role,
                 const std::string& caption, const std::string& alt, int* images) {
  const std::string relative = path.substr(d.dir.size() + 1);
  if (!IsPlainFileBelow(d.dir, path)) {
    return "<figure class=\"tile missing\" data-role=\"" + Html(role) + "\"><div>–</div>" +
           "<figcaption>" + Html(caption) + "</figcaption></figure>";
  }
  ++*images;
  const std::string href = Html(UrlPath(d.href_root + relative));
  return "<figure class=\"tile\" data-role=\"" + Html(role) + "\"><a class=\"view\" href=\"" +
         href + "\"><img class=\"thumb\" loading=\"lazy\" alt=\"" + Html(alt) + "\" src=\"" + href +
         "\"></a><figcaption>" + Html(caption) + "</figcaption></figure>";
}

// The viewer: hidden until a tile is clicked (PageScript).
void WriteViewer(std::ostringstream& html) {
  html << "<div id=\"viewer\" hidden role=\"dialog\" aria-label=\"image viewer\">\n"
          "<div class=\"vbar\"><b id=\"vtitle\"></b>\n"
          "<button type=\"button\" id=\"vside\">side by side</button>"
          "<button type=\"button\" id=\"vslide\">slider</button>"
          "<label>slider against <select id=\"vagainst\"><option value=\"clean\">clean</option>"
          "<option value=\"degraded\">degraded</option></select></label>"
          "<button type=\"button\" id=\"vprev\" title=\"previous image (←)\">◀</button>"
          "<button type=\"button\" id=\"vnext\" title=\"next image (→)\">▶</button>"
          "<button type=\"button\" id=\"vclose\" title=\"close (Esc)\">✕ close</button></div>\n"
          "<div id=\"vside-panels\" class=\"vpanels\">"
          "<figure><img id=\"vclean\" alt=\"clean\"><figcaption>clean</figcaption></figure>"
          "<figure><img id=\"vdegraded\" alt=\"degraded\"><figcaption>degraded input"
          "</figcaption></figure>"
          "<figure><img id=\"vmethod\" alt=\"method\"><figcaption id=\"vmethod-cap\">"
          "</figcaption></figure></div>\n"
          "<div id=\"vslide-panel\" hidden><div><div class=\"vstack\"><img "
          "id=\"vbase\" alt=\"\">"
          "<img id=\"vtop\" alt=\"\"></div>"
          "<input type=\"range\" id=\"vrange\" min=\"0\" max=\"100\" value=\"50\" "
          "aria-label=\"slider position\"></div><p id=\"vslide-cap\"></p></div>\n"
          "</div>\n";
}

}  // namespace

int WriteImageSection(std::ostringstream& html, const ReportData& d, int max_rows) {
  const Experiment& e = d.sweep->experiment;
  int images = 0;
  html << "<h2 id=\"images\">Images</h2>\n<p>The first item of each scene and " << Html(d.axis)
       << ", as the sweep saved it (sRGB PNG, at most " << e.thumbnail_width
       << " pixels wide: the experiment's <code>thumbnails</code>; 4096 keeps every image at full "
          "size). Click an image to see it at full size beside the clean image and the degraded "
          "input, or over either with a slider; ← → step through the item's images, Esc "
          "closes.</p>\n";
  if (e.thumbnail_width == 0) html << "<p>Thumbnails are off in this experiment.</p>\n";
  std::set<std::pair<std::string, std::string>> shown;
  int rows = 0;
  for (const ItemResult& item : d.sweep->items) {
    if (rows >= max_rows) break;
    if (!shown.insert({item.scene, item.level}).second) continue;
    ++rows;
    const std::string thumbs = d.dir + "/thumbs/" + item.id;
    html << "<section class=\"item\" data-item=\"" << Html(item.id) << "\"><h3>" << Html(item.id)
         << " <small>" << Html(d.axis) << " = " << Html(item.level)
         << "</small></h3>\n<div class=\"strip\">"
         << Tile(d, d.dir + "/thumbs/" + item.scene + "/clean.png", "clean", "clean",
                 item.scene + " clean", &images);
    if (e.ground_truth == "lit")
      html << Tile(d, thumbs + "/lit.png", "lit", "lit J", item.id + " lit", &images);
    html << Tile(d, thumbs + "/degraded.png", "degraded", "degraded", item.id + " degraded",
                 &images);
    for (const ExperimentMethod& m : e.methods) {
      if (m.name == "none") continue;
      html << Tile(d, thumbs + "/" + m.label + ".png", "method", MethodName(m),
                   item.id + " " + m.label, &images);
    }
    html << "</div></section>\n";
  }
  WriteViewer(html);
  return images;
}

std::string PageStyle() {
  return R"CSS(body{font-family:sans-serif;margin:1.5em auto;max-width:1240px;padding:0 1em;color:#222}
h1{margin-bottom:0.2em}nav a{margin-right:1em}
.tablewrap{max-width:100%;overflow:auto;max-height:85vh;margin:0.5em 0 1.2em}
table{border-collapse:separate;border-spacing:0}
td,th{border-bottom:1px solid #ccc;padding:3px 8px;text-align:right;white-space:nowrap}
thead th{position:sticky;top:0;z-index:2;background:#eee;border-bottom:2px solid #555;vertical-align:bottom}
tbody th{text-align:left;font-weight:normal;position:sticky;left:0;background:#fff;z-index:1}
thead th:first-child{left:0;z-index:3;text-align:left}
tr.group th{background:#f4f4f4;font-weight:bold;font-style:italic;text-align:left;position:static}
tr.ref th,tr.ref td{color:#555}
td .ci{display:block;font-size:0.78em;color:#555}
td.best{font-weight:bold}td.tie u{text-decoration-style:dotted}
tfoot td,tfoot th{font-size:0.8em;color:#444;white-space:normal;text-align:left;border-top:2px solid #555}
.legend{font-size:0.9em;background:#f8f8f8;border-left:4px solid #999;padding:0.4em 0.8em}
pre{background:#f6f6f6;padding:0.6em;overflow:auto;max-height:30em}
figure.plot{margin:0.5em 0 1.5em}figure.plot img{max-width:100%;height:auto;border:1px solid #ddd}
.plotrow{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}
.plotrow figure{flex:1 1 600px;min-width:0}
.strip{display:flex;flex-wrap:wrap;gap:6px}
.tile{margin:0;width:150px;font-size:0.8em;text-align:center}
.tile img{width:150px;height:auto;display:block;cursor:zoom-in;background:#ddd;min-height:40px}
.tile.missing div{height:100px;background:#eee;line-height:100px}
.item h3{margin:1em 0 0.3em;font-size:1em}
.warn{color:#a40}
#viewer{position:fixed;inset:0;background:#181818;color:#eee;z-index:10;overflow:auto;padding:0.5em 1em}
#viewer[hidden],#vslide-panel[hidden],#vside-panels[hidden]{display:none}
.vbar{display:flex;flex-wrap:wrap;gap:0.5em;align-items:center;margin-bottom:0.5em}
.vbar b{margin-right:1em}
.vpanels{display:flex;gap:0.5em}.vpanels figure{flex:1 1 0;min-width:0;margin:0;text-align:center}
.vpanels img{width:100%;height:auto;image-rendering:pixelated}
.vstack{position:relative;width:100%;height:calc(100vh - 120px)}
.vstack img{position:absolute;left:0;top:0;width:100%;height:100%;object-fit:contain;image-rendering:pixelated}
#vrange{width:100%;max-width:100%}
@media print{.tablewrap{max-height:none;overflow:visible}thead th,tbody th{position:static}#viewer{display:none}}
)CSS";
}

// The self-check a headless browser test reads (#check), after the viewer's own load handler.
static std::string CheckScript() {
  return R"JS((function () {
  // #check: loads every image and every linked image, then records in the DOM what a headless
  // browser test reads (tests/tools/report_browser_test.cc).
  function check() {
    var body = document.body, imgs = document.querySelectorAll('img.thumb, img.plot'), waits = [];
    function wait(img) {
      waits.push(new Promise(function (done) {
        if (img.complete && img.src) return done();
        img.addEventListener('load', done); img.addEventListener('error', done);
      }));
    }
    for (var i = 0; i < imgs.length; ++i) { imgs[i].loading = 'eager'; wait(imgs[i]); }
    var links = document.querySelectorAll('a.view'), probes = [];
    for (var j = 0; j < links.length; ++j) {
      var p = new Image(); p.src = links[j].href; probes.push(p); wait(p);
    }
    Promise.all(waits).then(function () {
      var bad = 0, badLinks = 0, plots = 0;
      for (var i = 0; i < imgs.length; ++i) if (imgs[i].naturalWidth === 0) ++bad;
      for (var j = 0; j < probes.length; ++j) if (probes[j].naturalWidth === 0) ++badLinks;
      var ps = document.querySelectorAll('img.plot');
      for (var k = 0; k < ps.length; ++k) if (ps[k].naturalWidth > 0) ++plots;
      var root = document.documentElement;
      body.setAttribute('data-images', imgs.length);
      body.setAttribute('data-broken-images', bad);
      body.setAttribute('data-links', probes.length);
      body.setAttribute('data-broken-links', badLinks);
      body.setAttribute('data-plots', plots);
      body.setAttribute('data-overflow-px', Math.max(0, root.scrollWidth - root.clientWidth));
      body.setAttribute('data-viewer-open', document.getElementById('viewer').hidden ? 0 : 1);
      body.setAttribute('data-check', 'done');
    });
  }
  window.addEventListener('load', function () {
    if (/check/.test(location.hash)) check();
  });
})();
)JS";
}

std::string PageScript() {
  return R"JS((function () {
  var cur = null, slider = false;
  function $(id) { return document.getElementById(id); }
  function tiles(item) { return item.querySelectorAll('figure.tile a.view'); }
  function roleSrc(item, role) {
    var f = item.querySelector('figure.tile[data-role="' + role + '"] a.view');
    return f ? f.getAttribute('href') : '';
  }
  function show() {
    var a = cur.link, item = cur.item, fig = a.parentNode;
    var name = fig.querySelector('figcaption').textContent;
    $('vtitle').textContent = item.getAttribute('data-item') + ' · ' + name;
    $('vclean').src = roleSrc(item, 'clean');
    $('vdegraded').src = roleSrc(item, 'degraded');
    $('vmethod').src = a.getAttribute('href');
    $('vmethod-cap').textContent = name;
    var against = $('vagainst').value;
    $('vbase').src = roleSrc(item, against);
    $('vtop').src = a.getAttribute('href');
    $('vslide-cap').textContent = 'left of the line: ' + against + ' · right: ' + name;
    $('vside-panels').hidden = slider;
    $('vslide-panel').hidden = !slider;
    clip();
  }
  function clip() { $('vtop').style.clipPath = 'inset(0 0 0 ' + $('vrange').value + '%)'; }
  function open(a, useSlider) {
    var item = a.closest('section.item');
    cur = {link: a, item: item};
    slider = !!useSlider;
    $('viewer').hidden = false;
    show();
  }
  function step(by) {
    var list = Array.prototype.slice.call(tiles(cur.item));
    var i = (list.indexOf(cur.link) + by + list.length) % list.length;
    cur.link = list[i];
    show();
  }
  function close() { $('viewer').hidden = true; cur = null; }
  document.addEventListener('click', function (ev) {
    var a = ev.target.closest && ev.target.closest('a.view');
    if (!a || ev.ctrlKey || ev.metaKey || ev.shiftKey) return;
    ev.preventDefault();
    open(a, false);
  });
  document.addEventListener('keydown', function (ev) {
    if (!cur) return;
    if (ev.key === 'Escape') close();
    if (ev.key === 'ArrowRight') step(1);
    if (ev.key === 'ArrowLeft') step(-1);
  });
  $('vclose').onclick = close;
  $('vprev').onclick = function () { step(-1); };
  $('vnext').onclick = function () { step(1); };
  $('vside').onclick = function () { slider = false; show(); };
  $('vslide').onclick = function () { slider = true; show(); };
  $('vagainst').onchange = show;
  $('vrange').oninput = clip;
  // #view=<item>/<index>[/slider] opens the viewer (links to one comparison; screenshots).
  function fromHash() {
    var m = /view=([^&\/]+)\/([0-9]+)(\/slider)?/.exec(location.hash);
    if (!m) return;
    var items = document.querySelectorAll('section.item');
    for (var k = 0; k < items.length; ++k) {
      if (items[k].getAttribute('data-item') !== decodeURIComponent(m[1])) continue;
      var a = tiles(items[k])[parseInt(m[2], 10)];
      if (a) open(a, !!m[3]);
    }
  }
  window.addEventListener('load', fromHash);
})();
)JS" + CheckScript();
}

}  // namespace turbid::report
