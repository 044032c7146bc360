"""Area files as search teams draw them (docs/search-team.md): KML exported by CalTopo and saved by
Google Earth Pro (and as a KMZ), KML written by GDAL (ogr2ogr, QGIS), GPX exported by CalTopo,
GeoPackage and Shapefile saved as QGIS saves them. Each holds the area of `gis/square.geojson`
and plans byte for byte what its GeoJSON twin plans; the plan's KML and GPX read back with GDAL;
bad files give one error line naming what is missing."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import textwrap
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pyogrio
import pyogrio.raw
import pytest
import shapely
from shapely.geometry import shape

from gcs.cli import main
from gcs.colours import uav_colour
from gcs.errors import UserError
from gcs.plans.area_file import read_area_file
from gcs.plans.gis_formats import area_sha256, description_values, role_name

HERE = Path(__file__).parent / "gis"
TWIN = HERE / "square.geojson"


def _features(kind: str | None = None) -> list[dict]:
    features = json.loads(TWIN.read_text())["features"]
    return [f for f in features if kind is None or f["geometry"]["type"] == kind]


def _write_layer(path: Path, layer: str, features: list[dict], driver: str, *, with_role: bool = True,
                 geometry_type: str | None = None, append: bool = False, crs: str = "EPSG:4326") -> None:
    """Features written as a GIS program writes them: one column per property (text where the
    values are not all numbers, as `heading` E and 315), empty where a feature has none."""
    keys = [k for k in dict.fromkeys(k for f in features for k in f["properties"]) if with_role or k != "role"]
    columns = []
    for key in keys:
        values = [f["properties"].get(key) for f in features]
        if all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in values):
            columns.append(np.array([np.nan if v is None else float(v) for v in values]))
        else:
            columns.append(np.array([None if v is None else str(v) for v in values], dtype=object))
    geometries = [shape(f["geometry"]) for f in features]
    if crs != "EPSG:4326":
        from pyproj import Transformer

        to_crs = Transformer.from_crs(4326, crs, always_xy=True)
        geometries = [shapely.transform(g, lambda xy: np.column_stack(to_crs.transform(xy[:, 0], xy[:, 1])))
                      for g in geometries]
    with warnings.catch_warnings():  # a Shapefile's cut column names, a LIBKML Camera without altitude
        warnings.simplefilter("ignore", RuntimeWarning)
        pyogrio.raw.write(path, np.array([shapely.to_wkb(g) for g in geometries], dtype=object), columns, keys,
                          layer=layer, driver=driver, crs=crs, append=append,
                          geometry_type=geometry_type or features[0]["geometry"]["type"])


def _zip(files: list[Path], path: Path, names: list[str] | None = None) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for file, name in zip(files, names or [f.name for f in files]):
            z.write(file, name)
    return path


def caltopo_kml(folder: Path) -> Path:
    return Path(shutil.copy(HERE / "caltopo.kml", folder / "square.kml"))


def google_earth_kml(folder: Path) -> Path:
    return Path(shutil.copy(HERE / "google-earth.kml", folder / "square.kml"))


def google_earth_kmz(folder: Path) -> Path:
    """Google Earth Pro's "Save Place As... (.kmz)": the document as doc.kml in a zip."""
    return _zip([HERE / "google-earth.kml"], folder / "square.kmz", ["doc.kml"])


def ogr2ogr_kml(folder: Path) -> Path:
    """`ogr2ogr -f KML square.kml square.geojson`: one Folder, the properties as ExtendedData."""
    path = folder / "square.kml"
    _write_layer(path, "square", _features(), "KML", geometry_type="Unknown")
    return path


def caltopo_gpx(folder: Path) -> Path:
    return Path(shutil.copy(HERE / "caltopo.gpx", folder / "square.gpx"))


def geopackage_with_roles(folder: Path) -> Path:
    """QGIS: a polygon layer and a point layer, each with a `role` column."""
    path = folder / "square.gpkg"
    _write_layer(path, "zones", _features("Polygon"), "GPKG")
    _write_layer(path, "points", _features("Point"), "GPKG", append=True)
    return path


def geopackage_layer_per_role(folder: Path) -> Path:
    """QGIS: one layer per role (named after it), no `role` column."""
    path = folder / "square.gpkg"
    for k, role in enumerate(("area", "no_fly", "prior", "airport", "target")):
        _write_layer(path, role, [f for f in _features() if f["properties"]["role"] == role], "GPKG",
                     with_role=False, append=k > 0)
    return path


def shapefile_folder(folder: Path) -> Path:
    """QGIS "Save Features As... ESRI Shapefile", once per layer, into one folder (column names
    cut to 10 characters)."""
    path = folder / "square"
    path.mkdir()
    _write_layer(path / "zones.shp", "zones", _features("Polygon"), "ESRI Shapefile")
    _write_layer(path / "points.shp", "points", _features("Point"), "ESRI Shapefile")
    return path


def shapefile_zip(folder: Path) -> Path:
    (folder / "parts").mkdir()
    shapes = shapefile_folder(folder / "parts")
    return _zip(sorted(shapes.iterdir()), folder / "square.zip")


TWINS = [caltopo_kml, google_earth_kml, google_earth_kmz, ogr2ogr_kml, caltopo_gpx, geopackage_with_roles,
         geopackage_layer_per_role, shapefile_folder, shapefile_zip]


def _plan(area: Path, out: Path) -> dict[str, str]:
    """Every file `gcs plan --area` writes but the picture, with the input file's path and hash
    and the output folder in plan.json replaced by AREA, SHA256 and OUT."""
    assert main(["plan", "--area", str(area), "--out", str(out), "--no-rrd", "--quiet"]) == 0
    files = {p.name: p.read_text() for p in sorted(out.iterdir()) if p.suffix != ".png"}
    record = json.loads(files["plan.json"])["campaign"]
    assert record["area"] == {"file": str(area.resolve()), "sha256": area_sha256(area)}
    assert record["sorties"][0]["folder"] == str(out)
    files["plan.json"] = files["plan.json"].replace(str(area.resolve()), "AREA").replace(
        area_sha256(area), "SHA256").replace(str(out), "OUT")
    return files


@pytest.fixture(scope="module")
def geojson_plan(tmp_path_factory) -> dict[str, str]:
    folder = tmp_path_factory.mktemp("geojson")
    return _plan(Path(shutil.copy(TWIN, folder / "square.geojson")), folder / "out")


@pytest.mark.parametrize("make", TWINS, ids=lambda make: make.__name__)
def test_an_area_plans_as_its_geojson_twin_plans(make, geojson_plan, tmp_path):
    """plan.json byte for byte (but the input file's path and hash), and every other file."""
    (tmp_path / "in").mkdir()
    files = _plan(make(tmp_path / "in"), tmp_path / "out")
    assert files.keys() == geojson_plan.keys()
    assert '"file": "AREA"' in files["plan.json"] and len(files["plan.json"]) > 10_000
    for name, text in files.items():
        assert text == geojson_plan[name], name


def test_every_property_comes_through(tmp_path):
    """The twins give the same typed values to the planner, read field by field."""
    twin = read_area_file(TWIN)
    for make in TWINS:
        folder = tmp_path / make.__name__
        folder.mkdir()
        mine = read_area_file(make(folder))
        assert mine.airports == twin.airports, make.__name__
        assert mine.targets == twin.targets and mine.cell_size_m == 30.0, make.__name__
        assert [(p.name, p.tep, p.eu) for p in mine.priors] == [("likely", 0.9, 0.8)], make.__name__
        assert mine.area.equals(twin.area) and [z.equals(t) for z, t in zip(mine.no_fly, twin.no_fly)] == [True]


def test_a_gpx_type_that_names_no_role_is_no_role(tmp_path):
    """A handheld's waypoint class (`<type>user</type>`) is left alone; its name gives the role."""
    path = tmp_path / "square.gpx"
    path.write_text((HERE / "caltopo.gpx").read_text().replace(
        "<name>target: hiker</name>", "<name>target: hiker</name><sym>Flag, Blue</sym><type>user</type>"))
    assert "<type>user</type>" in path.read_text()
    assert read_area_file(path).targets == read_area_file(TWIN).targets


def test_a_geopackage_in_another_crs_is_projected_to_wgs84(tmp_path):
    """A QGIS project in UTM (zone 32N here): the shapes come back in lon/lat to well under a
    millimetre."""
    path = tmp_path / "square.gpkg"
    _write_layer(path, "zones", _features("Polygon"), "GPKG", crs="EPSG:32632")
    _write_layer(path, "points", _features("Point"), "GPKG", append=True, crs="EPSG:32632")
    mine, twin = read_area_file(path), read_area_file(TWIN)
    assert shapely.equals_exact(mine.area, twin.area, tolerance=1e-8)
    for a, b in zip(mine.airports, twin.airports):
        assert abs(a.lon_deg - b.lon_deg) < 1e-8 and abs(a.lat_deg - b.lat_deg) < 1e-8
        assert (a.name, a.heading, a.range_m) == (b.name, b.heading, b.range_m)


def test_role_and_key_names_as_people_write_them():
    assert [role_name(n) for n in ("Area", "No-fly", "no fly", "NO_FLY", "nofly", "Priors", "airports", "Target",
                                   "No-fly zones", "Markers", "Shapes", None, 3)] == \
        ["area", "no_fly", "no_fly", "no_fly", "no_fly", "prior", "airport", "target", None, None, None, None, None]
    assert description_values("Role: Airport\nHeading = NE\nrange-m: 2500\nLaunch: car park\n") == \
        {"role": "Airport", "heading": "NE", "range_m": "2500"}
    assert description_values("<div>tep: 0.7<br/>eu: 0.5</div><p>EU &amp; TEP from the briefing</p>") == \
        {"tep": "0.7", "eu": "0.5"}
    assert description_values(None) == {} and description_values("just a note") == {}


def test_a_geojson_area_is_read_without_loading_gdal():
    script = textwrap.dedent(f"""
        import sys
        from gcs.plans.area_file import read_area_file
        read_area_file({str(TWIN)!r})
        print("pyogrio" in sys.modules, "gcs.plans.gis_formats" in sys.modules)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["False", "False"]


def test_the_plan_s_kml_and_gpx_read_back_with_gdal(geojson_plan, tmp_path):
    """paths.kml and paths.gpx hold paths.geojson: the same lines, names and properties, each UAV
    in its colour (as in plan.png)."""
    for name in ("paths.kml", "paths.gpx"):
        (tmp_path / name).write_text(geojson_plan[name])
    paths = json.loads(geojson_plan["paths.geojson"])["features"]
    assert len(paths) == 2
    assert pyogrio.read_info(tmp_path / "paths.kml")["driver"] == "LIBKML"
    kml_meta, _, kml_wkb, kml_fields = pyogrio.raw.read(tmp_path / "paths.kml", layer="paths")
    kml = dict(zip(kml_meta["fields"], kml_fields))
    assert list(kml["Name"]) == ["UAV 1 (west)", "UAV 2 (south-east)"]
    assert pyogrio.read_info(tmp_path / "paths.gpx", layer="tracks")["driver"] == "GPX"
    gpx_meta, _, gpx_wkb, gpx_fields = pyogrio.raw.read(tmp_path / "paths.gpx", layer="tracks")
    gpx = dict(zip(gpx_meta["fields"], gpx_fields))
    assert list(gpx["name"]) == ["UAV 1 (west)", "UAV 2 (south-east)"]
    for k, feature in enumerate(paths):
        line = np.asarray(feature["geometry"]["coordinates"])
        for wkb in (kml_wkb[k], gpx_wkb[k]):
            read = shapely.get_coordinates(shapely.from_wkb(wkb))
            assert read.shape == line.shape and np.abs(read - line).max() < 1e-9
        props = feature["properties"]
        assert (kml["uav"][k], kml["vehicle"][k], kml["altitude_m"][k], kml["waypoints"][k], kml["length_m"][k]) == \
            (props["uav"], props["vehicle"], props["altitude_m"], props["waypoints"], props["length_m"])
        assert int(gpx["ogr_uav"][k]) == props["uav"] and float(gpx["ogr_length_m"][k]) == props["length_m"]
    text = geojson_plan["paths.kml"]
    colours = [f"<color>ff{b:02x}{g:02x}{r:02x}</color>" for r, g, b in (uav_colour(0), uav_colour(1))]
    assert 0 < text.index(colours[0]) < text.index("UAV 2 (south-east)") < text.index(colours[1])


# ---- bad files: one error line, exit 2, nothing written -----------------------------------------------


def _fails(path: Path, match: str, capsys) -> str:
    out = path.parent / "out"
    assert main(["plan", "--area", str(path), "--out", str(out), "--quiet", "--no-rrd"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert match in lines[0], lines[0]
    assert not out.exists()
    return lines[0]


def _kml_without(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "square.kml"
    path.write_text(text)
    return path


def test_a_kml_without_an_area_polygon(tmp_path, capsys):
    text = (HERE / "caltopo.kml").read_text().replace("role: area\n", "")
    text = text.replace("<name>square</name>", "<name>search</name>")
    line = _fails(_kml_without(tmp_path, text), "folder 'Shapes', placemark 'search': no role", capsys)
    assert "a line 'role: ...' in the description" in line
    text = (HERE / "google-earth.kml").read_text()
    start = text.index("\t\t<Folder>\n\t\t\t<name>Area</name>")
    text = text[:start] + text[text.index("\t\t<Folder>\n\t\t\t<name>No-fly</name>"):]
    _fails(_kml_without(tmp_path, text), "square.kml: no area polygon: give the search area the role 'area'", capsys)


def test_a_kml_area_drawn_as_an_open_path(tmp_path, capsys):
    text = (HERE / "caltopo.kml").read_text()
    polygon = text[text.index("<Polygon>"):text.index("</Polygon>") + len("</Polygon>")]
    text = text.replace(polygon, "<LineString><coordinates>7.996056,46.997301,0 8.003944,46.997301,0 "
                                 "8.003945,47.002698,0</coordinates></LineString>", 1)
    _fails(_kml_without(tmp_path, text), "placemark 'square': the area needs an outline, got a line whose ends do not "
                                         "meet (draw it as a polygon)", capsys)


def test_a_placemark_with_two_roles_or_an_unknown_one(tmp_path, capsys):
    text = (HERE / "caltopo.kml").read_text().replace("<name>west</name>", "<name>target: west</name>")
    _fails(_kml_without(tmp_path, text), "placemark 'target: west': two roles given: airport (its description), "
                                         "target (its name)", capsys)
    text = (HERE / "caltopo.kml").read_text().replace("role: airport", "role: helipad")
    _fails(_kml_without(tmp_path, text), "its description gives the role 'helipad', not one of area, no_fly", capsys)


def test_a_kml_airport_whose_heading_gdal_wrote_as_a_camera(tmp_path, capsys):
    """GDAL's LIBKML driver writes a `heading` column as a Camera and `E` as heading 0: refused,
    never read as north."""
    path = tmp_path / "square.kml"
    _write_layer(path, "zones", _features("Polygon"), "LIBKML")
    _write_layer(path, "points", _features("Point"), "LIBKML", append=True)
    assert "<Camera>" in path.read_text()
    _fails(path, "placemark 'west': its heading was written as a KML Camera", capsys)


def test_a_gpx_without_a_route_or_track(tmp_path, capsys):
    text = (HERE / "caltopo.gpx").read_text()
    path = tmp_path / "square.gpx"
    path.write_text(text[:text.index("<trk>")] + "</gpx>\n")
    _fails(path, "square.gpx: no route or track to outline the area", capsys)
    path.write_text(text.replace("<type>airport</type>", ""))
    _fails(path, "square.gpx: waypoint 'west': no role; give it one of area, no_fly, prior, airport, target: a <type> "
                 "naming it", capsys)


def test_a_geopackage_layer_without_roles(tmp_path, capsys):
    path = tmp_path / "square.gpkg"
    _write_layer(path, "zones", _features("Polygon"), "GPKG", with_role=False)
    _write_layer(path, "points", _features("Point"), "GPKG", append=True)
    _fails(path, "square.gpkg: layer 'zones', feature 1 ('square'): no role; give it one of area, no_fly, prior, "
                 "airport, target: a 'role' column", capsys)


def test_a_lone_shapefile_says_where_the_airports_go(tmp_path, capsys):
    folder = shapefile_folder(tmp_path)
    _fails(folder / "zones.shp", "no airport (one point per UAV", capsys)
    assert "put the airports in a shapefile beside it and give the folder or a .zip of both" in \
        _fails(folder / "zones.shp", "zones.shp", capsys)


def test_unreadable_files(tmp_path, capsys):
    kml = tmp_path / "square.kml"
    kml.write_text((HERE / "caltopo.kml").read_text()[:900])
    _fails(kml, "square.kml: not a KML file GDAL can read (", capsys)
    kmz = tmp_path / "square.kmz"
    kmz.write_bytes(google_earth_kmz(tmp_path).read_bytes()[:300])
    _fails(kmz, "square.kmz: not a KMZ file GDAL can read", capsys)
    gpkg = tmp_path / "square.gpkg"
    gpkg.write_text("not a database")
    _fails(gpkg, "square.gpkg: not a GeoPackage GDAL can read", capsys)
    shutil.copy(TWIN, kml)
    _fails(kml, "square.kml: not a KML file GDAL can read (", capsys)
    gpx = tmp_path / "square.gpx"
    shutil.copy(TWIN, gpx)
    _fails(gpx, "square.gpx: GDAL reads this file as GeoJSON, not GPX file", capsys)
    _fails(tmp_path / "missing.gpx", "cannot read area file", capsys)
    text = tmp_path / "square.txt"
    text.write_text("<kml/>")
    _fails(text, "not JSON (Expecting value at line 1 column 1); area files are GeoJSON (.geojson, .json), KML "
                 "(.kml, .kmz), GPX (.gpx)", capsys)


def test_the_area_hash_covers_a_shapefile_s_attributes(tmp_path):
    folder = shapefile_folder(tmp_path)
    before = area_sha256(folder), area_sha256(folder / "points.shp")
    dbf = folder / "points.dbf"
    dbf.write_bytes(dbf.read_bytes().replace(b"west", b"east"))
    assert area_sha256(folder) != before[0] and area_sha256(folder / "points.shp") != before[1]
    with pytest.raises(UserError, match="points.shp: no area polygon"):
        read_area_file(folder / "points.shp")
