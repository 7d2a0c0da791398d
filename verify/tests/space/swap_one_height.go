// Two drones, airborne, swap places head-on at one height.
package SwapOneHeight

var (
	D1 Quadcopter
	D2 Quadcopter
)

func SEQ_Mission() {
	PAR_Up()
	PAR_Swap()
	PAR_Down()
}

func PAR_Up() {
	SEQ_Up1()
	SEQ_Up2()
}

func SEQ_Up1() {
	D1.Arm()
	D1.Takeoff(5)
}

func SEQ_Up2() {
	D2.Arm()
	D2.Takeoff(5)
}

func PAR_Swap() {
	D1.FlyByY(3)
	D2.FlyByY(-3)
}

func PAR_Down() {
	D1.Land()
	D2.Land()
}
