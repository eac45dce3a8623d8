# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader Editor user interface: the Add menu entries, the sidebar panel,
their operators, and the handlers: on load and render, a warning when a
scene using the node groups cannot run OSL; on render and save, the hybrid
mode's light linking and the lamp bindings brought up to date; on the
viewport's updates, the same at once where something changed (copied,
deleted, retyped or moved lamps, objects given or losing a hybrid
material).

Every class is registered from :data:`CLASSES` (plus the generated variant
menus), and :func:`unregister` removes exactly what :func:`register` added.
"""

from __future__ import annotations

import logging

import bpy
from bpy.app.handlers import persistent
from bpy.props import BoolProperty, EnumProperty, StringProperty

from . import api, groups, lighting
from .backends.native import build as native_build
from .core import catalogue
from .core.formulas import models as formulas

log = logging.getLogger(__name__)

OSL_OFF_WARNING = ("Reflection Models: this scene uses nodes forced to the OSL backend but "
                   "Open Shading Language is off; Cycles will render them black (choose the "
                   "'auto' backend to render native nodes there)")


def _in_shader_editor(context) -> bool:
    space = context.space_data
    return (space is not None and space.type == 'NODE_EDITOR'
            and space.tree_type == 'ShaderNodeTree')


def _active_rm_node(context):
    node = getattr(context, "active_node", None)
    return node if groups.is_rm_node(node) else None


# ---------------------------------------------------------------------------
# Operators

class NODE_OT_rm_add_model(bpy.types.Operator):
    bl_idname = "node.rm_add_model"
    bl_label = "Add Reflection Model"
    bl_description = "Add a Reflection Models node group to the shader tree"
    bl_options = {'REGISTER', 'UNDO'}

    model: StringProperty(name="Model", description="Model or preset id of the catalogue",
                          options={'HIDDEN'})
    distribution: StringProperty(name="Distribution", default="",
                                 description="Microfacet distribution (empty: the default)",
                                 options={'HIDDEN'})
    use_transform: BoolProperty(name="Use Transform", default=False,
                                description="Start moving the node after adding it",
                                options={'HIDDEN', 'SKIP_SAVE'})

    @classmethod
    def description(cls, _context, properties):
        name = properties.model
        if name in catalogue.PRESETS:
            return catalogue.PRESETS[name].description
        if name in catalogue.MODELS:
            text = catalogue.MODELS[name].description
            if properties.distribution:
                text += f" (distribution: {groups.choice_label(properties.distribution)})"
            return text
        return cls.bl_description

    @classmethod
    def poll(cls, context):
        space = context.space_data
        return (_in_shader_editor(context) and space.edit_tree is not None
                and space.edit_tree.is_editable)

    def execute(self, context):
        space = context.space_data
        tree = space.edit_tree
        enums = {"distribution": self.distribution} if self.distribution else {}
        try:
            group = groups.ensure_group(self.model, **enums)
        except (ValueError, RuntimeError, OSError) as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        for other in tree.nodes:
            other.select = False
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        if self.model in catalogue.PRESETS:
            node.label = catalogue.PRESETS[self.model].label
        node.location = space.cursor_location
        node.select = True
        tree.nodes.active = node
        obj = getattr(context, "object", None)
        if getattr(obj, "type", None) == 'CURVES' and groups.has_tangent(node):
            api.use_strand_tangent(node)  # hair: the UV tangent is 0 there
        return {'FINISHED'}

    def invoke(self, context, event):
        space = context.space_data
        if context.region is not None and context.region.type == 'WINDOW':
            space.cursor_location_from_region(event.mouse_region_x, event.mouse_region_y)
        else:
            space.cursor_location = space.edit_tree.view_center
        result = self.execute(context)
        if self.use_transform and 'FINISHED' in result:
            bpy.ops.node.translate_attach_remove_on_cancel('INVOKE_DEFAULT')
        return result


class NODE_OT_rm_enable_osl(bpy.types.Operator):
    bl_idname = "node.rm_enable_osl"
    bl_label = "Enable OSL"
    bl_description = ("Set the scene to render with Cycles on the CPU with Open Shading "
                      "Language on, which the Reflection Models nodes need")
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        api.enable_osl(context.scene)
        return {'FINISHED'}


class NODE_OT_rm_switch_variant(bpy.types.Operator):
    bl_idname = "node.rm_switch_variant"
    bl_label = "Switch Variant"
    bl_description = ("Give the active Reflection Models node another variant of its "
                      "model, keeping its socket values and links")
    bl_options = {'REGISTER', 'UNDO'}

    param: StringProperty(name="Parameter", options={'HIDDEN'})
    value: StringProperty(name="Value", options={'HIDDEN'})

    @classmethod
    def poll(cls, context):
        return _active_rm_node(context) is not None

    def execute(self, context):
        node = _active_rm_node(context)
        try:
            _tree, reset = groups.switch_variant(node, **{self.param: self.value})
        except (ValueError, RuntimeError, OSError) as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        if reset:
            self.report({'INFO'}, "Reset to the default (not allowed with "
                        f"{self.value}): {', '.join(reset)}")
        return {'FINISHED'}


_LIGHT_ITEMS = []  # Blender needs the strings of dynamic enum items kept alive


def _light_items(_self, context):
    _LIGHT_ITEMS.clear()
    scene = getattr(context, "scene", None)
    objects = scene.objects if scene is not None else bpy.data.objects
    for obj in sorted(objects, key=lambda o: o.name):
        if obj.type == 'LIGHT' and obj.data.type in api.SUPPORTED_LIGHTS:
            _LIGHT_ITEMS.append((obj.name, obj.name, f"{obj.data.type.title()} light",
                                 {'SUN': 'LIGHT_SUN', 'SPOT': 'LIGHT_SPOT'}.get(
                                     obj.data.type, 'LIGHT_POINT'), len(_LIGHT_ITEMS)))
    if not _LIGHT_ITEMS:
        _LIGHT_ITEMS.append(("", "No sun, point or spot lamp", "The scene has no sun, point "
                             "or spot lamp", 'ERROR', 0))
    return _LIGHT_ITEMS


class NODE_OT_rm_bind_light(bpy.types.Operator):
    bl_idname = "node.rm_bind_light"
    bl_label = "Bind Light"
    bl_description = ("Drive the Light inputs of the active Reflection Models node from one "
                      "sun, point or spot lamp (exact mode follows the lamp)")
    bl_options = {'REGISTER', 'UNDO'}
    bl_property = "light"

    light: EnumProperty(name="Light", description="Sun, point or spot lamp to follow",
                        items=_light_items)

    @classmethod
    def poll(cls, context):
        return _active_rm_node(context) is not None

    def execute(self, context):
        obj = bpy.data.objects.get(self.light)
        if obj is None:
            self.report({'ERROR'}, "Choose a sun, point or spot lamp")
            return {'CANCELLED'}
        try:
            api.bind_light(_active_rm_node(context), obj)
        except ValueError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        return {'FINISHED'}

    def invoke(self, context, event):
        if self.properties.is_property_set("light"):  # chosen in a menu or a button
            return self.execute(context)
        obj = context.active_object
        if obj is not None and obj.type == 'LIGHT' and obj.data.type in api.SUPPORTED_LIGHTS:
            self.light = obj.name
            return self.execute(context)
        context.window_manager.invoke_search_popup(self)
        return {'RUNNING_MODAL'}


def _selected_lamps(context):
    """The selected sun, point and spot lamps, the active one first."""
    objects = [o for o in getattr(context, "selected_objects", ()) or ()
               if o.type == 'LIGHT' and o.data.type in api.SUPPORTED_LIGHTS]
    active = context.active_object
    objects.sort(key=lambda o: (o != active, o.name))
    return objects


class NODE_OT_rm_bind_selected_lights(bpy.types.Operator):
    bl_idname = "node.rm_bind_selected_lights"
    bl_label = "Bind Selected Lamps"
    bl_description = ("Make exact mode follow the selected sun, point and spot lamps (up to "
                      "4, the active one first): one light of the node per lamp")
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _active_rm_node(context) is not None and bool(_selected_lamps(context))

    def execute(self, context):
        lamps = _selected_lamps(context)
        try:
            api.bind_light(_active_rm_node(context), *lamps)
        except ValueError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        self.report({'INFO'}, "Bound " + ", ".join(o.name for o in lamps))
        return {'FINISHED'}


MODE_ITEMS = [("path_traced", "Path Traced", "The BSDF output: Cycles closures, lit by every "
               "light of the scene"),
              ("exact", "Exact", "The Direct output: the model evaluated analytically for the "
               "bound lamps only"),
              ("hybrid", "Hybrid", "The bound lamps exactly, everything else (sky, other "
               "lamps, bounces) path traced; the bound lamps are excluded from the material's "
               "objects by light linking")]


class NODE_OT_rm_set_mode(bpy.types.Operator):
    bl_idname = "node.rm_set_mode"
    bl_label = "Mode"
    bl_description = "Which output of the active node the material renders"
    bl_options = {'REGISTER', 'UNDO'}

    mode: EnumProperty(name="Mode", items=MODE_ITEMS)

    @classmethod
    def poll(cls, context):
        return _active_rm_node(context) is not None

    def execute(self, context):
        try:
            api.set_mode(_active_rm_node(context), self.mode)
        except ValueError as exc:  # inside a group whose output it cannot reach
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        return {'FINISHED'}


class NODE_OT_rm_sync_light_linking(bpy.types.Operator):
    bl_idname = "node.rm_sync_light_linking"
    bl_label = "Repair Light Linking"
    bl_description = ("Exclude the bound lamps from every object that uses a hybrid material "
                      "(and undo what is no longer needed), set the lights of deleted lamps to "
                      "strength 0, and bind again lamps whose type, collections or light data "
                      "changed; also done on render and save")
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, _context):
        released = lighting.release_deleted_lamps()
        rebound = lighting.rebind_changed_lamps()
        n = api.sync_light_linking()
        self.report({'INFO'}, f"Light linking: {n} change(s)"
                    + (f"; {released} light(s) of deleted lamps set to 0" if released else "")
                    + (f"; {rebound} light(s) bound again for their lamp's new type, "
                       "collections or light data" if rebound else ""))
        return {'FINISHED'}


class NODE_OT_rm_use_strand_tangent(bpy.types.Operator):
    bl_idname = "node.rm_use_strand_tangent"
    bl_label = "Use Strand Direction"
    bl_description = ("Feed the active node's Tangent input from the Geometry node's Tangent: "
                      "on hair curves the strand's direction (the default, the UV map's "
                      "tangent, is 0 there)")
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        node = _active_rm_node(context)
        return node is not None and groups.has_tangent(node)

    def execute(self, context):
        api.use_strand_tangent(_active_rm_node(context))
        return {'FINISHED'}


def unfed_tangent_on_curves(node) -> bool:
    """Whether ``node`` has a Tangent input left unconnected while a hair
    Curves object renders its material: there the default, the UV map's
    tangent, is 0."""
    socket = groups.input_sockets(node).get("tangent")
    if socket is None or socket.is_linked:
        return False
    materials = set(groups.materials_of(node))
    return any(obj.type == 'CURVES' and any(slot.material in materials
                                            for slot in obj.material_slots)
               for obj in bpy.data.objects)


class NODE_OT_rm_unbind_light(bpy.types.Operator):
    bl_idname = "node.rm_unbind_light"
    bl_label = "Unbind Lamps"
    bl_description = ("Remove what binding added: the drivers that make the active node's "
                      "Light inputs follow lamps, the extra lights, hybrid mode's light linking")
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        node = _active_rm_node(context)
        return node is not None and (bool(api.light_drivers(node))
                                     or lighting.light_count(node) > 1)

    def execute(self, context):
        api.unbind_light(_active_rm_node(context))
        return {'FINISHED'}


class NODE_OT_rm_apply_metal(bpy.types.Operator):
    bl_idname = "node.rm_apply_metal"
    bl_label = "Metal"
    bl_description = ("Make the active microfacet node a metal: conductor Fresnel with the "
                      "measured complex index of refraction n + ik")
    bl_options = {'REGISTER', 'UNDO'}

    metal: EnumProperty(
        name="Metal", description="Measured n and k at 650, 550 and 450 nm",
        items=[(name, name.title(), f"n = {n}, k = {k}")
               for name, (n, k) in catalogue.METALS.items()])

    @classmethod
    def poll(cls, context):
        node = _active_rm_node(context)
        return node is not None and groups.rm_info(node.node_tree)[0] == "microfacet"

    def execute(self, context):
        api.apply_metal(_active_rm_node(context), self.metal)
        return {'FINISHED'}


class NODE_OT_rm_upgrade_groups(bpy.types.Operator):
    bl_idname = "node.rm_upgrade_groups"
    bl_label = "Upgrade Groups"
    bl_description = ("Rebuild the Reflection Models node groups made by an older version "
                      "of the extension or for another Blender version's native nodes, "
                      "keeping the nodes' values and links")
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, _context):
        return bool(groups.find_outdated_groups())

    def execute(self, _context):
        outdated = groups.find_outdated_groups()
        for tree in outdated:
            try:
                groups.upgrade_group(tree)
            except (ValueError, RuntimeError, OSError) as exc:
                self.report({'ERROR'}, f"{tree.name}: {exc}")
                return {'CANCELLED'}
        self.report({'INFO'}, f"Upgraded {len(outdated)} node group(s)")
        return {'FINISHED'}


# ---------------------------------------------------------------------------
# Add menu

class NODE_MT_rm_add(bpy.types.Menu):
    bl_idname = "NODE_MT_rm_add"
    bl_label = "Reflection Models"
    bl_description = ("Classic reflection models as node groups: Open Shading Language where "
                      "it runs, native nodes elsewhere (every Cycles device, EEVEE)")

    def draw(self, _context):
        layout = self.layout
        for model in catalogue.MODELS.values():
            if any(p.name == "distribution" for p in model.params):
                layout.menu(NODE_MT_rm_add_microfacet.bl_idname, text=model.label)
            else:
                _add_operator(layout, model.id, model.label)
        layout.separator()
        for preset in catalogue.PRESETS.values():
            _add_operator(layout, preset.id, preset.label)


class NODE_MT_rm_add_microfacet(bpy.types.Menu):
    bl_idname = "NODE_MT_rm_add_microfacet"
    bl_label = "Microfacet"
    bl_description = catalogue.MODELS["microfacet"].description

    def draw(self, _context):
        layout = self.layout
        param = catalogue.MODELS["microfacet"].param("distribution")
        for choice in param.choices:
            _add_operator(layout, "microfacet", groups.choice_label(choice), distribution=choice)


def _add_operator(layout, model_id, text, **props):
    op = layout.operator(NODE_OT_rm_add_model.bl_idname, text=text)
    op.model = model_id
    for key, value in props.items():
        setattr(op, key, value)
    op.use_transform = True
    return op


def _draw_add_menu(self, context):
    if _in_shader_editor(context):
        self.layout.menu(NODE_MT_rm_add.bl_idname, icon='NODE_MATERIAL')


# ---------------------------------------------------------------------------
# Sidebar panel

def _variant_menu_id(param_name: str) -> str:
    return f"NODE_MT_rm_variant_{param_name}"


def _make_variant_menu(param_name: str):
    def draw(self, context):
        node = _active_rm_node(context)
        if node is None:
            return
        model_id, variant = groups.rm_info(node.node_tree)
        param = next((p for p in groups.variant_params(model_id) if p.name == param_name), None)
        for choice in (param.choices if param else ()):
            op = self.layout.operator(NODE_OT_rm_switch_variant.bl_idname,
                                      text=groups.choice_label(choice),
                                      icon='CHECKMARK' if variant.get(param_name) == choice
                                      else 'BLANK1')
            op.param = param_name
            op.value = choice

    return type(_variant_menu_id(param_name), (bpy.types.Menu,), {
        "bl_idname": _variant_menu_id(param_name),
        "bl_label": param_name.replace("_", " ").title(),
        "draw": draw,
    })


def _variant_param_names() -> list:
    names = []
    for model_id in catalogue.MODELS:
        for p in groups.variant_params(model_id):
            if p.name not in names:
                names.append(p.name)
    return names


class NODE_PT_rm_sidebar(bpy.types.Panel):
    bl_idname = "NODE_PT_rm_sidebar"
    bl_space_type = 'NODE_EDITOR'
    bl_region_type = 'UI'
    bl_category = "Reflection Models"
    bl_label = "Reflection Models"

    @classmethod
    def poll(cls, context):
        return _in_shader_editor(context)

    def draw(self, context):
        layout = self.layout
        _draw_osl(layout, context.scene)
        outdated = groups.find_outdated_groups()
        if outdated:
            box = layout.box()
            older, other = groups.outdated_counts(outdated)
            if older:
                box.label(text=f"{older} group(s) from an older version", icon='INFO')
            if other:
                box.label(text=f"{other} group(s) built for another Blender's native nodes",
                          icon='INFO')
            box.operator(NODE_OT_rm_upgrade_groups.bl_idname, icon='FILE_REFRESH')
        node = _active_rm_node(context)
        if node is None:
            layout.label(text="Select a Reflection Models node")
            return
        _draw_node(layout, context, node)


def _draw_osl(layout, scene):
    """Which shaders the scene renders the nodes with, and why."""
    box = layout.box()
    backend, reason = api.rendering_backend(scene)
    if backend == "osl":
        box.label(text="Renders with: OSL shaders", icon='CHECKMARK')
        box.label(text=reason)
    elif backend == "native":
        box.label(text="Renders with: native nodes", icon='NODETREE')
        box.label(text=reason)
        if scene.render.engine == 'CYCLES':
            box.operator(NODE_OT_rm_enable_osl.bl_idname, icon='SCRIPT')
    else:
        box.label(text="Nothing renders the nodes", icon='ERROR')
        box.label(text=reason)
    if backend != "osl" and "osl" in _kept(("backends", scene.as_pointer()),
                                           lambda: groups.scene_backends(scene)):
        box.label(text="A node forced to OSL renders black here", icon='ERROR')


def _draw_node(layout, context, node):
    model_id, variant = groups.rm_info(node.node_tree)
    model = catalogue.MODELS[model_id]
    box = layout.box()
    box.label(text=model.label, icon='NODE_MATERIAL')
    for p in groups.variant_params(model_id):
        row = box.row()
        split = row.split(factor=0.4)
        split.label(text=p.label)
        split.menu(_variant_menu_id(p.name), text=groups.choice_label(variant[p.name]))
    if model_id == "microfacet":
        box.operator_menu_enum(NODE_OT_rm_apply_metal.bl_idname, "metal", text="Metal Preset",
                               icon='MATERIAL')
    if unfed_tangent_on_curves(node):
        box.label(text="On hair curves the unconnected Tangent is 0 (no UV map there)",
                  icon='ERROR')
        box.operator(NODE_OT_rm_use_strand_tangent.bl_idname, icon='CURVES')
    box = layout.box()
    mode = api.get_mode(node)
    row = box.row()
    row.label(text="Mode")
    row.operator_menu_enum(NODE_OT_rm_set_mode.bl_idname, "mode",
                           text=dict((m, label) for m, label, _d in MODE_ITEMS)[mode])
    if mode != "exact":
        for text, icon in bsdf_status_lines(context.scene, node):
            box.label(text=text, icon=icon)
    bound = api.bound_lights(node)
    box.label(text="Lamps: " + (", ".join(o.name for o in bound) if bound
                                else "none (the Light inputs)"), icon='LIGHT')
    sized = lighting.sized_lamps(bound)
    if sized and mode != "path_traced":
        box.label(text="Taken as a direction or point, size ignored: " + ", ".join(sized),
                  icon='INFO')
    scaled = lighting.unevenly_scaled_spots(bound)
    if scaled and mode != "path_traced":
        box.label(text="Spot cone taken unscaled (Cycles scales it with the lamp's uneven "
                  "scale): " + ", ".join(scaled), icon='INFO')
    lamps = _selected_lamps(context)
    row = box.row(align=True)
    if lamps:
        row.operator(NODE_OT_rm_bind_selected_lights.bl_idname,
                     text="Bind " + ", ".join(o.name for o in lamps[:4]))
    row.operator_menu_enum(NODE_OT_rm_bind_light.bl_idname, "light", text="Bind One")
    if bound:
        box.operator(NODE_OT_rm_unbind_light.bl_idname, icon='X')
    outdated = lighting.outdated_bindings(node) if mode != "path_traced" else []
    if outdated:
        box.label(text="Bound by an earlier version, not following Cast Shadow or Disable in "
                  "Renders: " + ", ".join(o.name for o in outdated) + ": bind again", icon='INFO')
    deleted = lighting.deleted_lamp_lights(node) if mode != "path_traced" else []
    if deleted:
        box.label(text="Lamp deleted for light " + ", ".join(map(str, deleted))
                  + ": lit as before until the next update, render or save sets it to 0",
                  icon='ERROR')
        box.operator(NODE_OT_rm_sync_light_linking.bl_idname, icon='FILE_REFRESH')
    layer = getattr(context, "view_layer", None)
    unrendered = (lighting.unrendered_lamps(node, layer)
                  if mode != "path_traced" and layer is not None else [])
    if unrendered:
        box.label(text="Exact mode lights with lamps this view layer does not render (in "
                  "another scene's collections or in no scene's, or instanced): " + ", ".join(
                      o.name for o in unrendered), icon='INFO')
    blocked = lighting.shadow_linked_lamps(node) if mode != "path_traced" else []
    if blocked:
        box.label(text="Shadow linking not followed: exact mode's shadow ray sees every object "
                  "for " + ", ".join(o.name for o in blocked), icon='INFO')
    linked = lighting.light_linked_lamps(node) if mode == "exact" else []
    if linked:
        box.label(text="Light linking not followed: exact mode lights every object with the "
                  "material from " + ", ".join(o.name for o in linked), icon='INFO')
    rays = lighting.unfollowed_ray_lamps(node) if mode != "path_traced" else []
    if rays:
        box.label(text="Ray visibility not followed (Kajiya-Kay's diffuse and specular terms "
                  "share one light): " + ", ".join(o.name for o in rays), icon='INFO')
    factors = (lighting.eevee_factor_lamps(node, context.scene)
               if mode != "path_traced" else [])
    if factors:
        box.label(text="EEVEE's Diffuse and Specular light factors not followed by exact mode: "
                  + ", ".join(o.name for o in factors), icon='INFO')
    retyped = lighting.retyped_lamps(node) if mode != "path_traced" else []
    for lamp, was in retyped:
        box.label(text=f"{lamp.name}: bound as {was.title()}, now {lamp.data.type.title()}: " + (
            "bound again at the next update, render or save"
            if lamp.data.type in lighting.SUPPORTED_LIGHTS
            else "exact mode follows sun, point and spot lamps"), icon='ERROR')
    moved = lighting.moved_lamp_lights(node) if mode != "path_traced" else []
    if moved:
        box.label(text="Lamp in other or renamed collections or with other light data since "
                  "binding, or bound by an older version, for light " + ", ".join(
                      map(str, moved))
                  + ": bound again at the next update, render or save", icon='ERROR')
    rebind = bool(moved) or any(lamp.data.type in lighting.SUPPORTED_LIGHTS
                                for lamp, _was in retyped)
    if rebind and not deleted:
        box.operator(NODE_OT_rm_sync_light_linking.bl_idname, icon='FILE_REFRESH')
    if mode == "hybrid":
        _draw_hybrid_linking(box, context.scene, node, bound,
                             repair_shown=bool(deleted) or rebind)
    if mode != "path_traced" and api.rendering_backend(context.scene, node)[0] == "native":
        if not native_build.has_raycast():
            box.label(text="Blender 4.5 native nodes: exact mode casts no shadows", icon='INFO')
        elif lighting.is_eevee(context.scene):
            box.label(text="EEVEE: exact mode's shadow ray is traced in screen space (only "
                      "what the view sees casts a shadow)", icon='INFO')


# What the sidebar reads that walks every object of the scene (which RM
# groups its materials use; a hybrid node's light-linking labels: up to
# 0.15 and 0.16 s at 10,000 objects, ``make bench``), read at its first
# redraw and kept for the next ones in the interactive UI until the next
# update of the depsgraph, undo or redo, file opened, render or save: a
# redraw alone (the pointer over the panel) changes nothing read.  Plain
# data, no Blender data, keyed by what was read.  Without a UI
# (background, scripts) nothing is redrawn and nothing is kept.
_kept_reads = {}


def _keeps_reads() -> bool:
    return not bpy.app.background


def forget_kept_reads(*_args):
    """Drop what the sidebar kept: something may have changed it."""
    _kept_reads.clear()


def _kept(key, read):
    """``read()``, kept between redraws of the interactive UI (above)."""
    if not _keeps_reads():
        return read()
    if key not in _kept_reads:
        _kept_reads[key] = read()
    return _kept_reads[key]


def _draw_hybrid_linking(box, scene, node, bound, repair_shown=False):
    """The sidebar's labels on a hybrid node's light linking: what Blender's
    light linking cannot do as the mode wants, and what is out of date
    (with the button that brings it up to date, unless ``repair_shown``);
    kept between redraws of the interactive UI until the next update."""
    key = ("hybrid", scene.as_pointer(), node.id_data.as_pointer(), node.name,
           tuple(lamp.as_pointer() for lamp in bound), bool(repair_shown))
    items = _kept(key, lambda: hybrid_linking_labels(scene, node, bound, repair_shown))
    for text, icon in items:
        if text is None:
            box.operator(NODE_OT_rm_sync_light_linking.bl_idname, icon=icon)
        else:
            box.label(text=text, icon=icon)


def hybrid_linking_labels(scene, node, bound, repair_shown=False) -> tuple:
    """What :func:`_draw_hybrid_linking` draws, read now: ``(text, icon)``
    per label, text None for the repair operator's button."""
    out = []
    hybrid = lighting.hybrid_bindings()  # read once for the labels below
    partly = lighting.also_other_materials(node, hybrid)
    if partly:
        out.append((f"{len(partly)} excluded object(s) also use other materials, "
                    "which the bound lamps no longer light", 'INFO'))
    linked = lighting.receiver_collections(scene) if bound else 0
    if linked > lighting.RECEIVER_COLLECTIONS_MAX:
        out.append((f"{linked} light linking collections in the scene; Blender applies at "
                    f"most {lighting.RECEIVER_COLLECTIONS_MAX}: some links are ignored",
                    'ERROR'))
    need = lighting.needed_exclusions(evaluate=False, hybrid=hybrid)
    missing = lighting.out_of_sync(evaluate=False, need=need)
    if missing:
        out.append(("Some objects are not excluded from the bound lamps", 'ERROR'))
    stray = lighting.stray_lamps(need)
    if stray:
        out.append(("Bound to no node, yet not lighting the hybrid objects (a copy of a "
                    "bound lamp?): " + ", ".join(o.name for o in stray), 'ERROR'))
    if (missing or stray) and not repair_shown:
        out.append((None, 'FILE_REFRESH'))
    from_library = lighting.linked_lamps(node)
    if from_library:
        remedy = ("make a library override" if lighting.override_keeps_light_linking()
                  else "make it local")
        out.append((f"Linked from a library, so their light linking is not saved ({remedy}): "
                    + ", ".join(o.name for o in from_library), 'ERROR'))
    sharers = lighting.unbound_sharers(need)
    if sharers:
        out.append(("Not lighting the hybrid objects, sharing a bound lamp's light linking "
                    "collection: " + ", ".join(o.name for o in sharers), 'INFO'))
    return tuple(out)


_STATUS_TEXT = {
    "exact": ("BSDF output: exact (a Cycles closure is the model)", 'CHECKMARK'),
    "near": ("BSDF output: near (Cycles' closure, under 1 % off)", 'CHECKMARK'),
    "fitted": (f"BSDF output: fitted (within {formulas.FIT_BOUND:g} of the peak)", 'CHECKMARK'),
    "approx": ("BSDF output: approximate (Direct is exact)", 'INFO'),
    "none": ("BSDF output: not rendered", 'ERROR'),
}


def bsdf_status_lines(scene, node) -> list:
    """``[(text, icon), ...]``: how the node's BSDF output matches the model
    with the scene's current settings (:func:`api.bsdf_accuracy`): the
    status, then the fitter's measured difference and where it holds, or
    why none is given."""
    accuracy = api.bsdf_accuracy(node, scene)
    status, error, note = accuracy["status"], accuracy["max_abs_over_peak"], accuracy["note"]
    lines = [_STATUS_TEXT[status]]
    if status in ("exact", "near"):
        return lines
    if error is None:
        return lines + [(note[:1].upper() + note[1:], 'BLANK1')]
    lines += [(f"Measured: at most {error:.2g} of the peak off", 'BLANK1'),
              (f"{note[:1].upper() + note[1:]}, views and lights to 70°", 'BLANK1')]
    detail = accuracy.get("detail")
    return lines + ([(detail[:1].upper() + detail[1:], 'BLANK1')] if detail else [])


# ---------------------------------------------------------------------------
# Handlers

def check_scene(scene) -> str | None:
    """The warning for ``scene`` if it uses RM groups it cannot render (a
    group forced to the OSL backend where OSL does not run), else None.
    Groups on the 'auto' or 'native' backend render everywhere."""
    if "osl" not in groups.scene_backends(scene):
        return None
    problems, _warnings = api.osl_status(scene)
    if not problems:
        return None
    if "Open Shading Language is off" in problems and scene.render.engine == 'CYCLES':
        message = OSL_OFF_WARNING
        others = [p for p in problems if p != "Open Shading Language is off"]
    else:
        message = ("Reflection Models: this scene uses nodes forced to the OSL backend but "
                   "cannot run OSL; they will render black")
        others = problems
    if others:
        message += " (also: " + "; ".join(others) + ")"
    return f"{message} [scene {scene.name!r}]"


@persistent
def on_load_post(*_args):
    forget_kept_reads()
    _objects_seen[0] = _slots_seen[0] = None  # another file: look at its first update
    for scene in bpy.data.scenes:
        message = check_scene(scene)
        if message:
            log.warning(message)
    message = outdated_groups_message()
    if message:
        log.warning(message)
    _logged(groups.mend_engine_switches, "mend the groups' switches between the engines",
            "%d switch(es) between the engines of older groups mended (EEVEE 5.3.0 crashed "
            "on them)")


def outdated_groups_message():
    """What ``load_post`` logs where the file holds groups an older version
    built or planned for another Blender's native nodes (None: none)."""
    older, other = groups.outdated_counts()
    if not older and not other:
        return None
    why = "; ".join(
        ([f"{older} by an older version of the extension"] if older else [])
        + ([f"{other} for another Blender version's native nodes (its shadow ray and "
            "conductor Fresnel)"] if other else []))
    return (f"Reflection Models: node groups of this file were built {why}: the sidebar's "
            "Upgrade Groups or api.upgrade_groups() rebuilds them, keeping values and links")


@persistent
def on_render_init(scene, *_args):
    message = check_scene(scene)
    if message:
        log.warning(message)
    _sync_light_linking(in_render=True)


@persistent
def on_save_pre(*_args):
    _sync_light_linking()


# what :func:`on_depsgraph_update_post` last saw: the number of objects, and
# object session uid -> its slots' materials (``lighting.slot_materials``); None:
# not read yet (since the extension was enabled, a file was opened, an undo or a redo)
_objects_seen = [None]
_slots_seen = [None]
# what a handler catches, so as never to stop a render, a save or an update
_FAILURES = (AttributeError, RuntimeError, ReferenceError, TypeError)
# :func:`_logged`'s arguments for the lights whose bound lamp was deleted
_RELEASE_DELETED = (lambda: lighting.release_deleted_lamps(),
                    "release the lights of deleted lamps",
                    "%d light(s) whose lamp was deleted set to strength 0")
# and for the lamps whose type, collections or light data changed since binding
_REBIND_CHANGED = (lambda: lighting.rebind_changed_lamps(),
                   "bind again a lamp whose type, collections or light data changed",
                   "%d light(s) bound again for their lamp's new type, collections or light "
                   "data")


@persistent
def on_depsgraph_update_post(_scene=None, depsgraph=None, *_args):
    """The viewport's updates, so that what it shows is put right at once
    rather than at the next render or save (measured before: until then a
    copy of a bound lamp lit the hybrid objects not at all, exact mode lit
    them from a deleted lamp and took a retyped lamp as its old type, and an
    object given a hybrid material was lit twice, by the closure and by the
    exact evaluation):

    - after a light or a collection was edited where a lamp's type, light
      data or collections changed (measured, 5.2.4 and 4.5.15: an edit of a
      light's energy, colour or type updates the light and not the
      collections; a lamp moved to another collection, a collection
      hidden or excluded, a lamp given other light data update the
      collections; a collection's Disable in Renders and exclusion, which
      the drivers read, change nothing read here; appending updates every
      kind of data, and what it brings changes the count of materials or
      node groups, also read here), and at the first update
      after the extension was enabled, a file opened, an undo or a redo:
      a bound lamp whose type changed (a sun made a spot lamp), that is
      now in other or renamed collections (whose Disable in Renders and
      view-layer exclusion its strength follows), that has other light
      data, or that an older version bound, bound again;
    - after objects were added or removed (their number changed): a copy
      of a bound lamp, which Blender gives the original's light linking,
      has the extension's collection taken away, and the lights of a
      deleted bound lamp are set to 0;
    - when an object's slots got or lost a material with a bound hybrid
      node (a new object with one, Shift D of one, a slot changed; for an
      object that instances or has Geometry Nodes, the materials it
      renders), when the materials with one changed (a hybrid node
      deleted, a material removed), and at the first update after the
      extension was enabled, a file opened, an undo or a redo: the hybrid
      exclusions brought up to date, reading the depsgraphs Blender keeps
      (nothing evaluated) and linking and unlinking objects only.

    An update that does not update the scene (moving objects) costs one
    question to the depsgraph; one that does, a count of the objects and
    a look at the updated objects' slots, and one of a material or node
    tree (a node edited) a look at the materials' hybrid nodes
    (``make bench``).  Skipped for a render's depsgraph and while a render
    runs (its handlers have done it).  Every update first drops what the
    sidebar kept (:func:`forget_kept_reads`)."""
    forget_kept_reads()
    if getattr(depsgraph, "mode", 'VIEWPORT') != 'VIEWPORT':
        return
    is_job_running = getattr(bpy.app, "is_job_running", None)
    if is_job_running is not None and is_job_running('RENDER'):
        return
    updated = getattr(depsgraph, "id_type_updated", None)
    first = _slots_seen[0] is None  # since enabling, a file opened, an undo or a redo
    if updated is not None and not updated('SCENE') and not first:
        # a transform or an edit of existing data: adding or removing an object and changing
        # a slot rebuild the depsgraph's relations, which updates the scene (measured)
        return
    if first or updated is None or ((updated('COLLECTION') or updated('LIGHT'))
                                    and _lamps_or_materials_changed()):
        # at the first look too: a file's older bindings; an edit of a light's energy or
        # colour, or of a collection's switches, changes nothing this reads: not read again
        _logged(*_REBIND_CHANGED)
    count = len(bpy.data.objects)
    if count != _objects_seen[0]:
        _objects_seen[0] = count
        _logged(*_RELEASE_DELETED)
        _logged(lambda: lighting.release_stray_lamps(), "update a copied lamp's light linking",
                "%d lamp(s) bound to no node now light the hybrid objects")
    try:
        changed = _exclusions_changed(depsgraph, updated)
    except _FAILURES as exc:
        log.warning("Reflection Models: could not read the objects' material slots: %s", exc)
        return
    if changed:
        _update_linking("update")


def _lamps_or_materials_changed() -> bool:
    """:func:`lighting.lamps_or_materials_changed`, True where it cannot be
    read (the bindings' reading then logs what failed)."""
    try:
        return lighting.lamps_or_materials_changed()
    except _FAILURES:
        return True


def _exclusions_changed(depsgraph, updated) -> bool:
    """Whether the hybrid exclusions may need an update since the last
    update: an object's slots got or lost a material with a bound hybrid
    node, or the set of those materials changed (a hybrid node deleted, a
    material removed: read when a material or node tree was updated).
    When nothing was read yet, every object is read, and True if any
    hybrid node is bound.  An object that instances or has Geometry Nodes
    counts with the materials it renders in ``depsgraph`` (a Set Material
    node's changed, say).  ``updated``: the depsgraph's ``id_type_updated``
    (None: taken as every type updated)."""
    graph = depsgraph if isinstance(depsgraph, bpy.types.Depsgraph) else None
    seen = _slots_seen[0]
    if seen is None:
        _slots_seen[0] = {o.session_uid: lighting.slot_materials(o, graph)
                          for o in bpy.data.objects}
        lighting.SYNCED_HYBRID[0] = lighting.hybrid_material_ids()
        return bool(lighting.SYNCED_HYBRID[0])
    changed = set()
    for update in getattr(depsgraph, "updates", ()):
        if not (update.is_updated_shading or update.is_updated_geometry):
            continue  # a transform: no slot changed
        obj = update.id.original
        if not isinstance(obj, bpy.types.Object):
            continue
        now, before = lighting.slot_materials(obj, graph), seen.get(obj.session_uid, ())
        if now != before:
            seen[obj.session_uid] = now
            changed |= set(now) ^ set(before)
    if not changed and updated is not None and not (updated('MATERIAL')
                                                    or updated('NODETREE')):
        return False
    before, now = lighting.SYNCED_HYBRID[0] or set(), lighting.hybrid_material_ids()
    lighting.SYNCED_HYBRID[0] = now
    return now != before or bool(changed & (now | before))


@persistent
def on_undo_redo_post(*_args):
    """Undo and redo bring back a state the viewport's handler may not have
    put right (Duplicate's, stored before the handler ran), with as many
    objects as it last saw: look again at the next update."""
    forget_kept_reads()
    _objects_seen[0] = _slots_seen[0] = None


def _logged(step, failed: str, done: str) -> int:
    """``step()``, a count of changes, logged (``done`` with the count, if
    any); a failure is logged as what could not be done (``failed``) and
    never stops a render, a save or an update."""
    try:
        n = step()
    except _FAILURES as exc:
        log.warning("Reflection Models: could not %s: %s", failed, exc)
        return 0
    if n:
        log.info("Reflection Models: " + done, n)
    return n


def _sync_light_linking(in_render=False):
    """Hybrid mode's light linking for objects that got or lost a hybrid
    material since, the lights whose bound lamp was deleted, and those
    whose lamp's type, collections or light data changed (bound again:
    measured in a render handler, the render then the same as after
    binding by hand, to the bit).  What the sidebar kept is dropped."""
    forget_kept_reads()
    _logged(*_RELEASE_DELETED)
    _logged(*_REBIND_CHANGED)
    _update_linking("render" if in_render else None)


def _update_linking(handler=None):
    """The hybrid exclusions brought up to date (``lighting.sync_light_linking``
    with ``handler``), logged."""
    _logged(lambda: lighting.sync_light_linking(handler=handler),
            "update the light linking", "light linking updated (%d change(s))")


HANDLERS = (("load_post", on_load_post), ("render_init", on_render_init),
            ("save_pre", on_save_pre), ("depsgraph_update_post", on_depsgraph_update_post),
            ("undo_post", on_undo_redo_post), ("redo_post", on_undo_redo_post))

CLASSES = (
    NODE_OT_rm_add_model,
    NODE_OT_rm_enable_osl,
    NODE_OT_rm_switch_variant,
    NODE_OT_rm_bind_light,
    NODE_OT_rm_bind_selected_lights,
    NODE_OT_rm_set_mode,
    NODE_OT_rm_sync_light_linking,
    NODE_OT_rm_unbind_light,
    NODE_OT_rm_use_strand_tangent,
    NODE_OT_rm_apply_metal,
    NODE_OT_rm_upgrade_groups,
    NODE_MT_rm_add,
    NODE_MT_rm_add_microfacet,
    NODE_PT_rm_sidebar,
)

_registered = []


def register():
    variant_menus = [_make_variant_menu(name) for name in _variant_param_names()]
    for cls in CLASSES + tuple(variant_menus):
        bpy.utils.register_class(cls)
        _registered.append(cls)
    bpy.types.NODE_MT_shader_node_add_all.append(_draw_add_menu)
    for name, func in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if func not in handlers:
            handlers.append(func)


def unregister():
    forget_kept_reads()
    for name, func in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        while func in handlers:
            handlers.remove(func)
    bpy.types.NODE_MT_shader_node_add_all.remove(_draw_add_menu)
    while _registered:
        bpy.utils.unregister_class(_registered.pop())
