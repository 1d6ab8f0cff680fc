//! `#[derive(ActivityBlock)]`: rust-hdl's `Block` for the controller's blocks, with an
//! activity-driven `update_all` (see `rtl::activity` for the rules it relies on and what it
//! guarantees).
//!
//! `connect_all` and `accept` are what rust-hdl's `LogicBlock` derive writes (every field but the
//! `Activity` one, in declaration order), so the generated Verilog and the connectivity checks see
//! the same design. Only the simulation differs: `update_all` latches the block's inputs first (when
//! the parent's kernel wrote them), runs the kernel only when something it reads changed, then loads
//! its `DFF`s on a rising edge of `clock`, and visits a child only when the kernel ran, the clock
//! moved or the child is still active.
//!
//! Fields are told apart by their type: `Signal<In, Clock>` (the clock, named `clock`), other
//! `Signal<In, _>` (inputs), `Signal<Out, _>` (outputs), `Signal<Local, _>` (the kernel's temporaries),
//! `Constant<_>`, `DFF<_>` (registers), `Activity` (the bookkeeping, exactly one) and anything
//! else (a child block implementing `rtl::activity::Child`). A block without a clock input is
//! purely combinational (no registers, no children): its kernel runs when an input changed.
//!
//! A field marked `#[interface]` is a port group (a rust-hdl `LogicInterface`: a struct of `In`
//! and `Out` signals, declared once and connected with one `link`/`join` in a kernel): its signals
//! are latched before the kernel like inputs and after it like outputs.

use proc_macro::TokenStream;
use proc_macro2::{Ident, TokenStream as TokenStream2};
use quote::quote;
use syn::{
    parse_macro_input, Data, DeriveInput, Error, Fields, GenericArgument, PathArguments, Type,
};

/// What a field is to the activity-driven settle.
enum Role {
    Clock,
    Input,
    Written { output: bool },
    Constant,
    Register,
    Activity,
    Child,
    Interface,
}

/// The last path segment of a type and its generic type arguments.
fn type_parts(ty: &Type) -> Option<(String, Vec<&Type>)> {
    let Type::Path(path) = ty else { return None };
    let segment = path.path.segments.last()?;
    let arguments = match &segment.arguments {
        PathArguments::AngleBracketed(args) => args
            .args
            .iter()
            .filter_map(|a| match a {
                GenericArgument::Type(t) => Some(t),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    };
    Some((segment.ident.to_string(), arguments))
}

fn type_name(ty: &Type) -> Option<String> {
    type_parts(ty).map(|(name, _)| name)
}

fn role(ty: &Type) -> Result<Role, String> {
    let Some((name, arguments)) = type_parts(ty) else {
        return Err("an ActivityBlock field must be a named type (no arrays or tuples)".into());
    };
    Ok(match name.as_str() {
        "Signal" => {
            let direction = arguments.first().and_then(|t| type_name(t));
            let data = arguments.get(1).and_then(|t| type_name(t));
            match direction.as_deref() {
                Some("In") if data.as_deref() == Some("Clock") => Role::Clock,
                Some("In") => Role::Input,
                Some("Out") => Role::Written { output: true },
                Some("Local") => Role::Written { output: false },
                _ => return Err("an ActivityBlock signal must be In, Out or Local".into()),
            }
        }
        "Constant" => Role::Constant,
        "DFF" => Role::Register,
        "Activity" => Role::Activity,
        _ => Role::Child,
    })
}

/// Derives rust-hdl's `Block` with an activity-driven `update_all`, and `rtl::activity::Child`.
#[proc_macro_derive(ActivityBlock, attributes(interface))]
pub fn derive_activity_block(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    match activity_block(&input) {
        Ok(tokens) => tokens.into(),
        Err(error) => error.to_compile_error().into(),
    }
}

fn activity_block(input: &DeriveInput) -> syn::Result<TokenStream2> {
    let name = &input.ident;
    let Data::Struct(data) = &input.data else {
        return Err(Error::new_spanned(input, "ActivityBlock needs a struct"));
    };
    let Fields::Named(fields) = &data.fields else {
        return Err(Error::new_spanned(
            input,
            "ActivityBlock needs named fields",
        ));
    };

    let mut visited: Vec<&Ident> = Vec::new();
    let mut clock: Option<&Ident> = None;
    let mut inputs = Vec::new();
    let mut outputs = Vec::new();
    let mut registers = Vec::new();
    let mut children = Vec::new();
    let mut interfaces = Vec::new();
    let mut activity: Option<&Ident> = None;
    for field in &fields.named {
        let ident = field.ident.as_ref().expect("named field");
        let role = if field.attrs.iter().any(|a| a.path().is_ident("interface")) {
            Role::Interface
        } else {
            role(&field.ty).map_err(|m| Error::new_spanned(&field.ty, m))?
        };
        if !matches!(role, Role::Activity) {
            visited.push(ident);
        }
        match role {
            Role::Clock => {
                if clock.is_some() || ident != "clock" {
                    return Err(Error::new_spanned(
                        ident,
                        "an ActivityBlock has one clock input, named `clock`",
                    ));
                }
                clock = Some(ident);
            }
            Role::Input => inputs.push(ident),
            Role::Written { output: true } => outputs.push(ident),
            Role::Written { output: false } => {}
            Role::Constant => {}
            Role::Register => registers.push(ident),
            Role::Activity => {
                if activity.is_some() {
                    return Err(Error::new_spanned(ident, "only one Activity field"));
                }
                activity = Some(ident);
            }
            Role::Child => children.push(ident),
            Role::Interface => interfaces.push(ident),
        }
    }
    let Some(activity) = activity else {
        return Err(Error::new_spanned(
            name,
            "an ActivityBlock needs a field of type `Activity` (rtl::activity::Activity)",
        ));
    };
    // A block without a clock is purely combinational: no registers, no children to clock.
    if clock.is_none() && (!registers.is_empty() || !children.is_empty()) {
        return Err(Error::new_spanned(
            name,
            "an ActivityBlock with registers or children needs a clock input `clock: Signal<In, Clock>`",
        ));
    }
    let latch_clock = match clock {
        Some(clock) => quote! {
            ::rust_hdl::core::block::Block::update_all(&mut self.#clock);
            let clock_changed = self.#clock.changed;
        },
        None => quote! { let clock_changed = false; },
    };
    let load_registers = match clock {
        Some(clock) => quote! {
            if self.#clock.pos_edge() {
                #(
                    if self.#registers.d.val() != self.#registers.q.val() {
                        self.#registers.q.next = self.#registers.d.val();
                        registers_changed = true;
                    }
                )*
            }
        },
        None => quote! {},
    };
    let visit_children = match clock {
        Some(clock) => quote! {
            let clock_level = self.#clock.val();
            #(
                if exhaustive
                    || run
                    || clock_changed
                    || !crate::activity::Child::settled(&self.#children)
                {
                    crate::activity::Child::drive_clock(&mut self.#children, clock_level);
                    crate::activity::Child::visit(&mut self.#children, run);
                    children_changed |= !crate::activity::Child::settled(&self.#children);
                }
            )*
        },
        None => quote! {},
    };
    let drive_clock = match clock {
        Some(clock) => quote! { self.#clock.next = level; },
        None => quote! { let _ = level; },
    };
    let visited_names: Vec<String> = visited.iter().map(|i| i.to_string()).collect();
    let (impl_generics, type_generics, where_clause) = input.generics.split_for_impl();

    Ok(quote! {
        impl #impl_generics ::rust_hdl::core::block::Block for #name #type_generics #where_clause {
            fn connect_all(&mut self) {
                ::rust_hdl::core::logic::Logic::connect(self);
                #(::rust_hdl::core::block::Block::connect_all(&mut self.#visited);)*
            }

            fn update_all(&mut self) {
                crate::activity::Child::visit(self, true);
            }

            fn has_changed(&self) -> bool {
                self.#activity.changed
            }

            fn accept(&self, name: &str, probe: &mut dyn ::rust_hdl::core::probe::Probe) {
                probe.visit_start_scope(name, self);
                #(::rust_hdl::core::block::Block::accept(&self.#visited, #visited_names, probe);)*
                probe.visit_end_scope(name, self);
            }
        }

        impl #impl_generics crate::activity::Child for #name #type_generics #where_clause {
            fn visit(&mut self, inputs_written: bool) {
                // Inputs: only the parent's kernel (or the testbench) writes them, so they can
                // have changed only if it ran since the last visit.
                let mut inputs_changed = false;
                if inputs_written {
                    #(
                        ::rust_hdl::core::block::Block::update_all(&mut self.#inputs);
                        inputs_changed |= self.#inputs.changed;
                    )*
                    #(
                        ::rust_hdl::core::block::Block::update_all(&mut self.#interfaces);
                        inputs_changed |=
                            ::rust_hdl::core::block::Block::has_changed(&self.#interfaces);
                    )*
                }
                #latch_clock
                let exhaustive = self.#activity.exhaustive;
                let run = exhaustive
                    || !self.#activity.started
                    || inputs_changed
                    || self.#activity.rerun
                    #(|| crate::activity::Child::outputs_changed(&self.#children))*;
                // The kernel. Its outputs and locals read back what it wrote (`val()` of an `Out` or
                // `Local` is `next`); register inputs `d` are latched, so a change is read next pass.
                let mut outputs_changed = false;
                let mut d_changed = false;
                if run {
                    ::rust_hdl::core::logic::Logic::update(self);
                    #(
                        ::rust_hdl::core::block::Block::update_all(&mut self.#outputs);
                        outputs_changed |= self.#outputs.changed;
                    )*
                    #(
                        ::rust_hdl::core::block::Block::update_all(&mut self.#interfaces);
                        outputs_changed |=
                            ::rust_hdl::core::block::Block::has_changed(&self.#interfaces);
                    )*
                    #(
                        ::rust_hdl::core::block::Block::update_all(&mut self.#registers.d);
                        d_changed |= self.#registers.d.changed;
                    )*
                }
                // Registers load on the rising edge, after the kernel: it has seen their old
                // values, and the inputs it wrote for the children are from before the edge too.
                #[allow(unused_mut)]
                let mut registers_changed = false;
                #load_registers
                #[allow(unused_mut)]
                let mut children_changed = false;
                #visit_children
                self.#activity.started = true;
                self.#activity.rerun = d_changed || registers_changed;
                self.#activity.outputs_changed = outputs_changed;
                self.#activity.changed = inputs_changed
                    || clock_changed
                    || outputs_changed
                    || d_changed
                    || registers_changed
                    || children_changed;
            }

            fn drive_clock(&mut self, level: ::rust_hdl::core::clock::Clock) {
                #drive_clock
            }

            fn settled(&self) -> bool {
                !self.#activity.changed
            }

            fn outputs_changed(&self) -> bool {
                self.#activity.outputs_changed
            }

            fn set_exhaustive(&mut self, exhaustive: bool) {
                self.#activity.exhaustive = exhaustive;
                #(crate::activity::Child::set_exhaustive(&mut self.#children, exhaustive);)*
            }
        }
    })
}

/// Derives `Default` for a block whose constants carry their values: a `Constant<T>` field needs
/// `#[constant(value)]` (any expression `T` converts from, such as a `u64`); any other field may
/// name its initial value with `#[init(expression)]` (a RAM's contents); every other field is
/// `Default::default()`. One declaration per value instead of a hand-written `Default` that lists
/// every field of the block.
#[proc_macro_derive(BlockDefault, attributes(constant, init))]
pub fn derive_block_default(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    match block_default(&input) {
        Ok(tokens) => tokens.into(),
        Err(error) => error.to_compile_error().into(),
    }
}

fn block_default(input: &DeriveInput) -> syn::Result<TokenStream2> {
    let name = &input.ident;
    let Data::Struct(data) = &input.data else {
        return Err(Error::new_spanned(input, "BlockDefault needs a struct"));
    };
    let Fields::Named(fields) = &data.fields else {
        return Err(Error::new_spanned(input, "BlockDefault needs named fields"));
    };
    let mut values = Vec::new();
    for field in &fields.named {
        let ident = field.ident.as_ref().expect("named field");
        let value = field
            .attrs
            .iter()
            .find(|a| a.path().is_ident("constant"))
            .map(|a| a.parse_args::<syn::Expr>())
            .transpose()?;
        let init = field
            .attrs
            .iter()
            .find(|a| a.path().is_ident("init"))
            .map(|a| a.parse_args::<syn::Expr>())
            .transpose()?;
        if let Some(init) = init {
            values.push(quote! { #ident: #init });
            continue;
        }
        let is_constant = type_name(&field.ty).as_deref() == Some("Constant");
        values.push(match (value, is_constant) {
            (Some(value), true) => quote! {
                #ident: ::rust_hdl::core::constant::Constant::new(::core::convert::Into::into(#value))
            },
            (None, false) => quote! { #ident: ::core::default::Default::default() },
            (None, true) => {
                return Err(Error::new_spanned(
                    ident,
                    "a Constant field needs its value: #[constant(value)]",
                ))
            }
            (Some(_), false) => {
                return Err(Error::new_spanned(
                    ident,
                    "#[constant(value)] belongs on a Constant field",
                ))
            }
        });
    }
    let (impl_generics, type_generics, where_clause) = input.generics.split_for_impl();
    Ok(quote! {
        impl #impl_generics ::core::default::Default for #name #type_generics #where_clause {
            fn default() -> Self {
                #name { #(#values,)* }
            }
        }
    })
}
