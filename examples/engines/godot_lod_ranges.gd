# godot_lod_ranges.gd - a Godot 4 import script for a sylva bake's lods.glb
# (docs/outputs.md, "LOD groups in engines"): it gives each level's meshes the
# visibility range (distance from the camera, metres) the bake planned, so
# Godot draws one level at a time, switching where the bake switches.
#
# Use: copy the bake folder into the project, select lods.glb in the
# FileSystem dock, and in the Import dock set "Import Script" to this file,
# then Reimport.
#
# Level i (node <asset>_LOD<i>) is drawn from the report's switch_distance of
# level i (0 for the first) to that of level i + 1 (no end for the last). The
# distances come from the nodes' glTF extras ("switch_distance", which
# Godot 4.3+ imports as the node's "extras" metadata) or, when the extras are
# not imported, from report.json beside lods.glb. They hold for the scene the
# bake was given (report.json "scene": screen_height, fov_deg): a camera with
# another field of view or resolution switches at other sizes.
@tool
extends EditorScenePostImport

var _from_report := {}


func _post_import(scene):
	var report := get_source_file().get_base_dir().path_join("report.json")
	if FileAccess.file_exists(report):
		var j = JSON.parse_string(FileAccess.get_file_as_string(report))
		if j is Dictionary and j.has("lods"):
			for l in j["lods"]:
				_from_report[l["node"]] = float(l["switch_distance"])
	var levels := []
	_collect(scene, levels)
	levels.sort_custom(func(a, b): return a[0] < b[0])
	for k in levels.size():
		var begin: float = 0.0 if k == 0 else levels[k][1]
		var end: float = levels[k + 1][1] if k + 1 < levels.size() else 0.0
		_set_range(levels[k][2], begin, end)
	return scene


# [lod index, switch distance, node] of every node named ..._LOD<i>
func _collect(node: Node, out: Array) -> void:
	var name := String(node.name)
	var at := name.rfind("_LOD")
	if at >= 0 and name.substr(at + 4).is_valid_int():
		var d := -1.0
		var extras = node.get_meta("extras", null)
		if extras is Dictionary and extras.has("switch_distance"):
			d = float(extras["switch_distance"])
		elif _from_report.has(name):
			d = _from_report[name]
		if d < 0.0:
			push_error("%s: no switch_distance in its extras or in report.json" % name)
		out.append([int(name.substr(at + 4)), d, node])
		return
	for c in node.get_children():
		_collect(c, out)


func _set_range(node: Node, begin: float, end: float) -> void:
	if node is GeometryInstance3D:
		node.visibility_range_begin = begin
		node.visibility_range_end = end
	for c in node.get_children():
		_set_range(c, begin, end)
